"""Frame pairs: each Gazebo frame beside racer's frame at the same pose; do policies read them alike?

The 92 Gazebo frames (`frames/gazebo_reinvent_episode`) carry no pose, but their painted lines do. The yellow centre
dashes and the white edge lines, projected onto the ground through the camera, fit re:Invent 2018's lines at one
pose: a search along the route (distance along it, offset, heading), coarse then fine, scores the mean distance of
the projected points to the centre line and to the edge lines' middles. racer renders its own frame there. Every
policy (the real checkpoints, and a racer model if given) then picks its greedy steering side on both frames of each
pair. A pair counts when the two frames' line masks overlap (IoU >= 0.5; the track repeats itself, so a fit may land
on a twin of the right place, which is as good for this purpose when the views match). A policy that reads racer's
frames as it reads Gazebo's picks the same side on both.

The control: the same policy on racer's frame and on racer's frame with the pose moved by a fit's size of error
(2 cm, 2 degrees, random): how often that alone flips the side. A pair agreement at that level is all a look change
could still explain.

The fit also says which camera took the frames: the projected lines fit best at the mount the projection assumes,
so `--camera-height` / `--camera-forward` try another (the older (0.2, 0, 0.164) m mount of SimApp version < 3).
"""

from __future__ import annotations

import json
import math
import os
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import click
import cv2
import numpy as np

from benchmarks.gazebo_frames import GAZEBO_FRAMES, load_gazebo_frames, render_poses
from benchmarks.workdir import cpu_description
from racer.shared.sim.car.vehicle import CAMERA_HORIZONTAL_FOV_RAD, CAMERA_PITCH_DOWN_RAD, CAMERA_POS_M
from racer.shared.sim.scene.world_look import EDGE_LINE_WIDTH_M
from research import data_option
from research.camera_proxies.grey_stats import paired_grey_stats
from research.frame_pairs.poses import FITTED_POSES

ROUTE = "routes/reinvent_base.npy"

RASTER_M = 0.01
"""Metres per cell of the line-distance rasters."""
MAX_RANGE_M = 2.2
"""Projected points farther than this are left out (a pixel there spans many centimetres of ground)."""
CLIP_M = 0.08
"""A point's distance to its line counts up to this much (robust to mis-coloured pixels)."""
GOOD_PAIR_IOU = 0.5
POSE_NOISE = (0.02, math.radians(2.0))
"""The control's pose error: metres in x and y, radians of heading (standard deviations)."""


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


def line_iou(first: np.ndarray, second: np.ndarray) -> float:
    """Overlap of two RGB frames' line masks (yellow with yellow, white with white; dilated by 2 pixels)."""
    kernel = np.ones((5, 5), np.uint8)
    masks = [[cv2.dilate(m.astype(np.uint8), kernel) > 0 for m in line_masks(frame)] for frame in (first, second)]
    both = sum(int((a & b).sum()) for a, b in zip(*masks, strict=True))
    either = sum(int((a | b).sum()) for a, b in zip(*masks, strict=True))
    return both / either if either else 0.0


def render_at(route: Path, poses: list[tuple[float, float, float]]) -> np.ndarray:
    """racer's RGB camera frames at the car poses (x, y, yaw): base world, the default render, racer's camera."""
    return render_poses(route, "base", poses, full_resolution=False)[0]


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


def grey_of(frames_rgb: np.ndarray) -> np.ndarray:
    from racer.shared.sim.sensors.camera import rgb_to_y

    return np.stack([rgb_to_y(frame) for frame in frames_rgb])


def side_agreement(first: np.ndarray, second: np.ndarray, where: np.ndarray | None = None) -> float:
    if where is not None:
        first, second = first[where], second[where]
    return round(float(np.mean(first == second)), 3) if len(first) else float("nan")


def pairs_picture(gazebo: np.ndarray, ours: np.ndarray, iou: np.ndarray, path: Path, columns: int = 4) -> None:
    """Each Gazebo frame with racer's frame at its fitted pose to the right; the pair's line IoU on top."""
    tiles = []
    for left, right, overlap in zip(gazebo, ours, iou, strict=True):
        tile = np.hstack([left, right, np.full((left.shape[0], 4, 3), 255, np.uint8)])
        colour = (40, 220, 40) if overlap >= GOOD_PAIR_IOU else (240, 60, 60)
        cv2.putText(tile, f"IoU {overlap:.2f}", (4, 12), cv2.FONT_HERSHEY_SIMPLEX, 0.4, colour, 1, cv2.LINE_AA)
        tiles.append(tile)
    while len(tiles) % columns:
        tiles.append(np.zeros_like(tiles[0]))
    grid = np.vstack([np.hstack(tiles[i : i + columns]) for i in range(0, len(tiles), columns)])
    path.parent.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(path), cv2.cvtColor(grid, cv2.COLOR_RGB2BGR))


def compare_policies(
    gazebo: np.ndarray, ours: np.ndarray, jittered: np.ndarray, good: np.ndarray, real: dict, racer: dict
) -> dict:
    """Per policy ({label: (metadata, network)}): steering-side agreement between the two frames of each pair (all,
    and the good pairs), the control (racer's frame against racer's frame at a jittered pose) and the shares; for a
    racer policy also its agreement with each real one, on the Gazebo frames and on racer's frames of the same poses."""
    from benchmarks.transfer import shares, steering_sides

    grey = {"gazebo": grey_of(gazebo), "racer": grey_of(ours), "jittered": grey_of(jittered)}
    sides = {
        label: {name: steering_sides(metadata, network, frames) for name, frames in grey.items()}
        for label, (metadata, network) in {**real, **racer}.items()
    }
    result = {}
    for label, own in sides.items():
        figures = {
            "pairs_all": side_agreement(own["gazebo"], own["racer"]),
            "pairs_good": side_agreement(own["gazebo"], own["racer"], good),
            "control_pose_noise": side_agreement(own["racer"], own["jittered"]),
            "shares_gazebo": shares(own["gazebo"]),
            "shares_racer": shares(own["racer"]),
        }
        if label in racer:
            figures["agreement_with_real"] = {
                other: {
                    "gazebo_frames": side_agreement(own["gazebo"], sides[other]["gazebo"]),
                    "racer_frames_same_poses": side_agreement(own["racer"], sides[other]["racer"]),
                }
                for other in real
            }
        result[label] = figures
    return result


def run_frame_pairs(
    data: Path, camera: CameraMount, jobs: int, limit: int | None, racer_model: Path | None, picture: Path | None
) -> dict:
    from benchmarks.transfer import import_real_models, model_folders

    started = time.perf_counter()
    route_path = data / ROUTE
    frames = load_gazebo_frames(data / GAZEBO_FRAMES)[:limit]
    route = np.load(route_path)
    print(f"frame-pairs: fitting {len(frames)} frames' poses ({jobs} processes)", file=sys.stderr, flush=True)
    fitted = fit_poses(frames, route, camera, jobs)
    poses = [(p.x_m, p.y_m, p.yaw_rad) for p in fitted]
    ours = render_at(route_path, poses)
    rng = np.random.default_rng(0)
    jittered_poses = [
        (x + rng.normal(0, POSE_NOISE[0]), y + rng.normal(0, POSE_NOISE[0]), yaw + rng.normal(0, POSE_NOISE[1]))
        for x, y, yaw in poses
    ]
    jittered = render_at(route_path, jittered_poses)
    iou = np.array([line_iou(g, o) for g, o in zip(frames, ours, strict=True)])
    good = iou >= GOOD_PAIR_IOU
    with tempfile.TemporaryDirectory(prefix="racer-frame-pairs-") as store_root:
        real = {
            model.label: (model.metadata, model.network)
            for model in import_real_models(model_folders(data / "models"), Path(store_root))
        }
    racer = racer_policies(racer_model) if racer_model is not None else {}
    by_policy = compare_policies(frames, ours, jittered, good, real, racer)
    if picture is not None:
        pairs_picture(frames, ours, iou, picture)
    return {
        "study": "frame-pairs",
        "cpu": cpu_description(),
        "frames": len(frames),
        "camera": camera.__dict__,
        "fit_cost_cm": {"median": round(float(np.median([p.cost_m for p in fitted])) * 100, 2)},
        "line_iou": {"median": round(float(np.median(iou)), 3), "good_pairs": int(good.sum())},
        "grey": paired_grey_stats(grey_of(ours), grey_of(frames)),
        "policies": by_policy,
        "poses": [{"x_m": round(x, 4), "y_m": round(y, 4), "yaw_rad": round(yaw, 4)} for x, y, yaw in poses],
        "picture": str(picture) if picture is not None else None,
        "wall_s": round(time.perf_counter() - started, 1),
    }


def racer_policies(model_folder: Path) -> dict[str, tuple]:
    """The last four checkpoints of a racer model folder (racer's local store layout)."""
    from benchmarks.transfer import open_racer_model

    metadata, checkpoints = open_racer_model(model_folder)
    return {f"racer:{name}": (metadata, checkpoints.load_policy(name)) for name in checkpoints.names()[-4:]}


@click.command(name="frame-pairs")
@data_option("Gazebo frames, re:Invent 2018 route, models/")
@click.option(
    "--racer-model",
    type=click.Path(exists=True, file_okay=False, path_type=Path),
    default=None,
    help="A racer model folder (racer-data/MODEL): its last four checkpoints are compared too.",
)
@click.option(
    "--picture", type=click.Path(dir_okay=False, path_type=Path), default=None, help="Write the pairs as a PNG."
)
@click.option(
    "--save-poses",
    type=click.Path(dir_okay=False, path_type=Path),
    default=None,
    help=f"Write the fitted poses as JSON ({FITTED_POSES.name} beside this study is this file, read by "
    "research/camera_proxies).",
)
@click.option("--frames", "limit", type=click.IntRange(1, None), default=None, help="Only the first N frames.")
@click.option("--jobs", type=click.IntRange(1, None), default=None, help="Processes fitting poses. Default: the cores.")
@click.option(
    "--camera-height",
    type=float,
    default=CameraMount.height_m,
    show_default=True,
    help="Metres; the camera the fit assumes took the Gazebo frames (racer renders with its own).",
)
@click.option(
    "--camera-forward", type=float, default=CameraMount.forward_m, show_default=True, help="Metres, as above."
)
def frame_pairs_command(
    data: Path,
    racer_model: Path | None,
    picture: Path | None,
    save_poses: Path | None,
    limit: int | None,
    jobs: int | None,
    camera_height: float,
    camera_forward: float,
) -> None:
    """Fit each Gazebo frame's pose from its lines, render racer's frame there, and compare policies on the pairs."""
    from racer.shared.sim.scene.gl import ensure_gl_backend

    ensure_gl_backend()
    camera = CameraMount(forward_m=camera_forward, height_m=camera_height)
    result = run_frame_pairs(data, camera, jobs or os.cpu_count() or 1, limit, racer_model, picture)
    if save_poses is not None:
        document = {
            "about": "Car poses of the Gazebo frames (frames/gazebo_reinvent_episode, in file order) "
            "on re:Invent 2018, "
            "fitted from their painted lines by `python -m research.frame_pairs`",
            "camera": result["camera"],
            "fit_cost_cm_median": result["fit_cost_cm"]["median"],
            "poses": result["poses"],
        }
        save_poses.write_text(json.dumps(document, indent=1) + "\n")
    click.echo(json.dumps(result))
