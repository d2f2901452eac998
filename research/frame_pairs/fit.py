"""The pose fit of the frame-pairs study: a frame's car pose on the route, found from its painted lines.

The yellow centre dashes and the white edge lines, projected onto the ground through the camera, fit re:Invent 2018's
lines at one pose: a search along the route (distance along it, offset, heading), coarse then fine, scores the mean
distance of the projected points to the centre line and to the edge lines' middles. The fit costs least at the mount
that took the frames, so `CameraMount` can be another than racer's.
"""

from __future__ import annotations

import math
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass

import cv2
import numpy as np

from racer.shared.sim.car.vehicle import CAMERA_HORIZONTAL_FOV_RAD, CAMERA_PITCH_DOWN_RAD, CAMERA_POS_M
from racer.shared.sim.scene.world_look import EDGE_LINE_WIDTH_M

RASTER_M = 0.01
"""Metres per cell of the line-distance rasters."""
MAX_RANGE_M = 2.2
"""Projected points farther than this are left out (a pixel there spans many centimetres of ground)."""
CLIP_M = 0.08
"""A point's distance to its line counts up to this much (robust to mis-coloured pixels)."""


@dataclass(frozen=True)
class CameraMount:
    """Where the camera sits on the car (origin on the ground) and how it looks."""

    forward_m: float = CAMERA_POS_M[0]
    height_m: float = CAMERA_POS_M[2]
    pitch_down_rad: float = CAMERA_PITCH_DOWN_RAD
    horizontal_fov_rad: float = CAMERA_HORIZONTAL_FOV_RAD


@dataclass(frozen=True)
class FramePose:
    """A frame's fitted car pose (origin) and the fit's mean point-to-line distance."""

    x_m: float
    y_m: float
    yaw_rad: float
    cost_m: float


def line_masks(rgb: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(yellow centre dashes, white edge lines) of an RGB frame, by hue, saturation and value."""
    hsv = cv2.cvtColor(rgb, cv2.COLOR_RGB2HSV).astype(np.int16)
    hue, saturation, value = hsv[..., 0], hsv[..., 1], hsv[..., 2]
    yellow = (hue >= 10) & (hue <= 35) & (saturation > 120) & (value > 120)
    white = (saturation < 60) & (value > 170)
    return yellow, white


def ground_points(mask: np.ndarray, camera: CameraMount) -> np.ndarray:
    """The mask's pixels projected onto flat ground: (N, 2) points, x forward and y left of the car's origin."""
    height_px, width_px = mask.shape
    rows, cols = np.nonzero(mask)
    focal_px = (width_px / 2) / math.tan(camera.horizontal_fov_rad / 2)
    right = (cols + 0.5 - width_px / 2) / focal_px
    up = -(rows + 0.5 - height_px / 2) / focal_px
    cos_p, sin_p = math.cos(camera.pitch_down_rad), math.sin(camera.pitch_down_rad)
    ray_forward, ray_down = cos_p + up * sin_p, sin_p - up * cos_p
    below_horizon = ray_down > 1e-3
    reach = camera.height_m / ray_down[below_horizon]
    x = camera.forward_m + reach * ray_forward[below_horizon]
    y = -reach * right[below_horizon]
    near = np.hypot(x, y) < MAX_RANGE_M
    return np.stack([x[near], y[near]], axis=1)


class RouteLines:
    """Distance rasters of a route's centre line and of its edge lines' middles (the lines lie inside the borders)."""

    def __init__(self, route: np.ndarray) -> None:
        rows = route.reshape(-1, 3, 2)
        self.center = rows[:, 0]
        self.origin = rows.reshape(-1, 2).min(axis=0) - 1.0
        far = rows.reshape(-1, 2).max(axis=0) + 1.0
        self.shape = tuple(int(n) for n in ((far - self.origin) / RASTER_M).astype(int)[::-1] + 1)
        edges = [self._inward(rows[:, 1]), self._inward(rows[:, 2])]
        self.to_center = self._distance([self.center])
        self.to_edge = self._distance(edges)
        closed = np.vstack([self.center, self.center[:1]])
        self.closed_center = closed
        self.s_m = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(closed, axis=0).T))])

    def _inward(self, border: np.ndarray) -> np.ndarray:
        towards_center = self.center - border
        return border + towards_center * (EDGE_LINE_WIDTH_M / 2 / np.linalg.norm(towards_center, axis=1, keepdims=True))

    def _distance(self, lines: list[np.ndarray]) -> np.ndarray:
        canvas = np.full(self.shape, 255, np.uint8)
        for line in lines:
            cells = np.round((np.vstack([line, line[:1]]) - self.origin) / RASTER_M).astype(np.int32)
            cv2.polylines(canvas, [cells], False, 0, 1)
        return cv2.distanceTransform(canvas, cv2.DIST_L2, 5) * RASTER_M

    @property
    def length_m(self) -> float:
        return float(self.s_m[-1])

    def lookup(self, raster: np.ndarray, xy: np.ndarray) -> np.ndarray:
        cells = np.round((xy - self.origin) / RASTER_M).astype(np.int64)
        col = np.clip(cells[..., 0], 0, self.shape[1] - 1)
        row = np.clip(cells[..., 1], 0, self.shape[0] - 1)
        return raster[row, col]

    def poses(self, s_m: np.ndarray, offsets_m: np.ndarray, heading_offsets_rad: np.ndarray) -> np.ndarray:
        """(N, 3) poses x, y, yaw: every combination of a distance along the centre line, a left offset from it and
        a heading relative to it."""
        s_m = np.mod(s_m, self.length_m)
        x = np.interp(s_m, self.s_m, self.closed_center[:, 0])
        y = np.interp(s_m, self.s_m, self.closed_center[:, 1])
        segment = np.clip(np.searchsorted(self.s_m, s_m, side="right") - 1, 0, len(self.center) - 1)
        step = self.closed_center[segment + 1] - self.closed_center[segment]
        heading = np.arctan2(step[:, 1], step[:, 0])
        i, offset, turn = np.meshgrid(np.arange(len(s_m)), offsets_m, heading_offsets_rad, indexing="ij")
        return np.stack(
            [
                (x[i] - offset * np.sin(heading[i])).ravel(),
                (y[i] + offset * np.cos(heading[i])).ravel(),
                (heading[i] + turn).ravel(),
            ],
            axis=1,
        )

    def fit_cost(self, poses: np.ndarray, yellow: np.ndarray, white: np.ndarray, chunk: int = 20000) -> np.ndarray:
        """Mean clipped distance (m) of the projected points to their lines, per pose."""
        costs = np.empty(len(poses))
        count = max(len(yellow) + len(white), 1)
        for start in range(0, len(poses), chunk):
            block = poses[start : start + chunk]
            cos_y, sin_y = np.cos(block[:, 2])[:, None], np.sin(block[:, 2])[:, None]
            total = np.zeros(len(block))
            for points, raster in ((yellow, self.to_center), (white, self.to_edge)):
                if len(points) == 0:
                    continue
                world_x = block[:, :1] + cos_y * points[None, :, 0] - sin_y * points[None, :, 1]
                world_y = block[:, 1:2] + sin_y * points[None, :, 0] + cos_y * points[None, :, 1]
                distance = self.lookup(raster, np.stack([world_x, world_y], axis=-1))
                total += np.minimum(distance, CLIP_M).sum(axis=1)
            costs[start : start + chunk] = total / count
        return costs


def _sample(points: np.ndarray, count: int, rng: np.random.Generator) -> np.ndarray:
    return points if len(points) <= count else points[rng.choice(len(points), count, replace=False)]


def fit_pose(rgb: np.ndarray, lines: RouteLines, camera: CameraMount = CameraMount(), seed: int = 0) -> FramePose:
    """The pose on the route whose lines best fit the frame's: a coarse search over the whole lap with a sample of
    the points, then a fine one around the eight best candidates with all of them."""
    rng = np.random.default_rng(seed)
    yellow_mask, white_mask = line_masks(rgb)
    yellow, white = ground_points(yellow_mask, camera), ground_points(white_mask, camera)
    coarse = lines.poses(
        np.arange(0.0, lines.length_m, 0.08), np.arange(-0.45, 0.451, 0.04), np.radians(np.arange(-60, 61, 4))
    )
    coarse_cost = lines.fit_cost(coarse, _sample(yellow, 70, rng), _sample(white, 110, rng))
    best = FramePose(0.0, 0.0, 0.0, math.inf)
    for index in np.argsort(coarse_cost)[:8]:
        x, y, yaw = coarse[index]
        s_m, offset_m, turn_rad = _route_coordinates(lines, x, y, yaw)
        fine = lines.poses(
            np.arange(s_m - 0.08, s_m + 0.081, 0.01),
            np.arange(offset_m - 0.04, offset_m + 0.041, 0.01),
            turn_rad + np.radians(np.arange(-4.0, 4.01, 0.5)),
        )
        fine_cost = lines.fit_cost(fine, yellow, white)
        j = int(np.argmin(fine_cost))
        if fine_cost[j] < best.cost_m:
            best = FramePose(float(fine[j, 0]), float(fine[j, 1]), float(fine[j, 2]), float(fine_cost[j]))
    return best


def _route_coordinates(lines: RouteLines, x: float, y: float, yaw: float) -> tuple[float, float, float]:
    """(distance along, left offset, heading offset) of a pose relative to the nearest centre-line point."""
    dense_s = np.arange(0.0, lines.length_m, 0.01)
    px = np.interp(dense_s, lines.s_m, lines.closed_center[:, 0])
    py = np.interp(dense_s, lines.s_m, lines.closed_center[:, 1])
    k = int(np.argmin(np.hypot(px - x, py - y)))
    on_route = lines.poses(dense_s[k : k + 1], np.zeros(1), np.zeros(1))[0]
    heading = on_route[2]
    offset = -(x - on_route[0]) * math.sin(heading) + (y - on_route[1]) * math.cos(heading)
    turn = (yaw - heading + math.pi) % (2 * math.pi) - math.pi
    return float(dense_s[k]), float(offset), float(turn)


def _fit_one(args: tuple[np.ndarray, np.ndarray, CameraMount, int]) -> FramePose:
    rgb, route, camera, seed = args
    return fit_pose(rgb, RouteLines(route), camera, seed)


def fit_poses(frames: np.ndarray, route: np.ndarray, camera: CameraMount, jobs: int) -> list[FramePose]:
    """Every frame's pose, `jobs` processes at a time (each fit is independent)."""
    work = [(frame, route, camera, index) for index, frame in enumerate(frames)]
    if jobs <= 1:
        return [_fit_one(item) for item in work]
    with ProcessPoolExecutor(max_workers=jobs) as pool:
        return list(pool.map(_fit_one, work))
