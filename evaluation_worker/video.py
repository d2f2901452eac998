"""MP4 videos of an evaluation: the in-car camera, a top view of the whole track, a 45-degree follow camera.

One frame per simtrace row, taken where that row's observation was taken, at 15 fps (DeepRacer's camera rate), so
a video plays in simulated real time and frame k is simtrace row k. Encoded with H.264 (yuv420p, ffmpeg through
imageio-ffmpeg), which browsers and Foxglove play.

Costs: the follow view is a MuJoCo render at 480x360, the dearest of the three; the top view is rendered once (the
track does not move, so obstacles and bot cars are left out of it) and the car, the obstacles and the bot cars are
drawn onto it with OpenCV; the in-car and follow views render the objects as the car's camera sees them; the in-car view
is the env's own RGB camera frame (`render_mode='rgb_array'`; stereo models: the centre camera), no extra render.
The car's geoms are hidden from the car camera (group 3), so the follow view turns that group on.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import cv2
import imageio.v2 as imageio
import numpy as np

from racer.evaluation_worker.config import VideoOptions
from racer.evaluation_worker.driver import StepRecord
from racer.shared.sim.car.vehicle import CAR_GEOM_GROUP
from racer.shared.sim.env import DeepRacerEnv
from racer.shared.sim.objects.bodies import OBJECT_GEOM_GROUP, drawn_size
from racer.shared.sim.objects.poses import ObjectKind, ObjectPose
from racer.shared.sim.scene._mujoco import mujoco

FPS = 15
VIEWS: tuple[str, ...] = ("camera-incar", "camera-topview", "camera-45degree")
"""Folder names, DeepRacer style (`camera-topview/0-video.mp4`, `camera-45degree/0-video.mp4`)."""
VIDEO_FILE = "0-video.mp4"
CAR_LENGTH_M = 0.30
CAR_WIDTH_M = 0.16
TOP_MARGIN_M = 0.4
TRAIL_STEPS = 45
INCAR_SCALE = 2
OBJECT_RGB = {ObjectKind.BOX_OBSTACLE: (123, 97, 79), ObjectKind.BOT_CAR: (40, 40, 40)}
_HUD_FONT = cv2.FONT_HERSHEY_SIMPLEX


class VideoError(RuntimeError):
    """The encoder failed; names the file."""


@dataclass(frozen=True)
class Projection:
    """World point on the ground -> pixel of a rendered free-camera image (MuJoCo's mono camera = eye average)."""

    position: np.ndarray
    right: np.ndarray
    up: np.ndarray
    forward: np.ndarray
    near: float
    half_height: float
    half_width: float
    center: float
    width_px: int
    height_px: int
    orthographic: bool

    @classmethod
    def from_scene(cls, scene: mujoco.MjvScene, width_px: int, height_px: int) -> Projection:
        left, right_eye = scene.camera[0], scene.camera[1]
        position = (np.asarray(left.pos, dtype=np.float64) + np.asarray(right_eye.pos, dtype=np.float64)) / 2.0
        forward = np.asarray(left.forward, dtype=np.float64)
        up = np.asarray(left.up, dtype=np.float64)
        half_height = (left.frustum_top - left.frustum_bottom) / 2.0
        # MuJoCo leaves frustum_width at 0 and derives it from the viewport's aspect ratio when rendering.
        half_width = left.frustum_width if left.frustum_width > 0 else half_height * width_px / height_px
        return cls(
            position,
            np.cross(forward, up),
            up,
            forward,
            float(left.frustum_near),
            float(half_height),
            float(half_width),
            float(left.frustum_center),
            width_px,
            height_px,
            bool(left.orthographic),
        )

    def to_pixels(self, points_xyz: np.ndarray) -> np.ndarray:
        rel = np.atleast_2d(points_xyz) - self.position
        xc, yc, zc = rel @ self.right, rel @ self.up, rel @ self.forward
        if not self.orthographic:
            xc, yc = xc * self.near / zc, yc * self.near / zc
        u = (xc - (self.center - self.half_width)) / (2.0 * self.half_width) * self.width_px
        v = (self.half_height - yc) / (2.0 * self.half_height) * self.height_px
        return np.stack((u, v), axis=-1)


def top_view_camera(env: DeepRacerEnv, width_px: int, height_px: int) -> mujoco.MjvCamera:
    """Straight down on the track's bounding box (image up = +y), at the distance that fits it with a margin."""
    rows = env.base_track.waypoints.reshape(-1, 3, 2)
    lo, hi = rows.min(axis=(0, 1)), rows.max(axis=(0, 1))
    mid = (lo + hi) / 2.0
    half = (hi - lo) / 2.0 + TOP_MARGIN_M
    tan_half_fovy = math.tan(math.radians(env.model.vis.global_.fovy) / 2.0)
    camera = mujoco.MjvCamera()
    camera.type = mujoco.mjtCamera.mjCAMERA_FREE
    camera.lookat[:] = (mid[0], mid[1], 0.0)
    camera.elevation = -90.0
    camera.azimuth = 90.0
    camera.distance = max(half[1] / tan_half_fovy, half[0] / (tan_half_fovy * width_px / height_px))
    return camera


def _object_outline(obj: ObjectPose) -> np.ndarray:
    length_m, width_m, _height_m = drawn_size(obj.kind)
    c, s = math.cos(obj.yaw_rad), math.sin(obj.yaw_rad)
    corners = [(length_m / 2, width_m / 2), (length_m / 2, -width_m / 2), (-length_m / 2, -width_m / 2)]
    corners.append((-length_m / 2, width_m / 2))
    return np.array([(obj.x_m + c * dx - s * dy, obj.y_m + s * dx + c * dy, 0.0) for dx, dy in corners])


def car_outline(x_m: float, y_m: float, yaw_rad: float) -> np.ndarray:
    """The car's top-view outline (a pointed rectangle: its nose shows the heading) on the ground, in metres."""
    c, s = math.cos(yaw_rad), math.sin(yaw_rad)
    corners = [
        (-CAR_LENGTH_M / 2, -CAR_WIDTH_M / 2),
        (CAR_LENGTH_M / 2, -CAR_WIDTH_M / 2),
        (CAR_LENGTH_M / 2 + 0.06, 0.0),
        (CAR_LENGTH_M / 2, CAR_WIDTH_M / 2),
        (-CAR_LENGTH_M / 2, CAR_WIDTH_M / 2),
    ]
    return np.array([(x_m + c * dx - s * dy, y_m + s * dx + c * dy, 0.0) for dx, dy in corners])


def _hud(image: np.ndarray, record: StepRecord, scale: float) -> None:
    row = record.row
    text = (
        f"t {float(row['tstamp']):6.2f}s  lap {record.lap_index + 1}  {float(row['progress']):5.1f}%  "
        f"resets {record.lap_resets}  {row['episode_status']}"
    )
    thickness = max(1, int(round(scale * 1.5)))
    origin = (4, int(14 * scale) + 2)
    cv2.putText(image, text, origin, _HUD_FONT, 0.4 * scale, (0, 0, 0), thickness + 2, cv2.LINE_AA)
    cv2.putText(image, text, origin, _HUD_FONT, 0.4 * scale, (255, 255, 255), thickness, cv2.LINE_AA)


class Mp4Encoder:
    """One H.264 MP4 at FPS, frame by frame (shared with the all-cars top view of multi-car races)."""

    def __init__(self, path: Path) -> None:
        path.parent.mkdir(parents=True, exist_ok=True)
        self.path = path
        self.frames = 0
        self._writer = imageio.get_writer(
            str(path),
            fps=FPS,
            codec="libx264",
            quality=None,
            pixelformat="yuv420p",
            macro_block_size=2,
            ffmpeg_log_level="error",
            output_params=["-preset", "ultrafast", "-crf", "23"],
        )

    def add(self, frame: np.ndarray) -> None:
        try:
            self._writer.append_data(frame)
        except (OSError, BrokenPipeError) as error:
            raise VideoError(f"{self.path}: ffmpeg stopped accepting frames: {error}") from error
        self.frames += 1

    def close(self) -> None:
        self._writer.close()


class VideoRecorder:
    """A StepObserver writing the three MP4s under `out_dir/<view>/0-video.mp4`."""

    def __init__(self, env: DeepRacerEnv, out_dir: Path, options: VideoOptions) -> None:
        if env.render_mode != "rgb_array":
            raise ValueError(
                "VideoRecorder needs the env made with render_mode='rgb_array' (its camera frame is the in-car view)"
            )
        self.options = options
        self.paths = {view: out_dir / view / VIDEO_FILE for view in VIEWS}
        width, height = options.width_px, options.height_px
        self._renderer = mujoco.Renderer(env.model, height=height, width=width)
        self._car_visible = mujoco.MjvOption()
        self._car_visible.geomgroup[CAR_GEOM_GROUP] = 1
        self._static_only = mujoco.MjvOption()
        self._static_only.geomgroup[OBJECT_GEOM_GROUP] = 0  # objects move: drawn onto each top frame instead
        self._objects: tuple[ObjectPose, ...] = ()
        self._follow = mujoco.MjvCamera()
        self._follow.type = mujoco.mjtCamera.mjCAMERA_FREE
        self._follow.distance = options.follow_distance_m
        self._follow.elevation = options.follow_elevation_deg
        self._top_camera = top_view_camera(env, width, height)
        self._top_background: np.ndarray | None = None
        self._top_projection: Projection | None = None
        self._trail: list[tuple[float, float]] = []
        self._pending: dict[str, np.ndarray] | None = None
        self._pending_pose: tuple[float, float, float] | None = None
        self._encoders = {view: Mp4Encoder(path) for view, path in self.paths.items()}

    @property
    def frame_counts(self) -> dict[str, int]:
        return {view: encoder.frames for view, encoder in self._encoders.items()}

    def _render_top_background(self, env: DeepRacerEnv) -> None:
        """Once, on the first step (the static geoms have their poses only after the env's first forward pass)."""
        width, height = self.options.width_px, self.options.height_px
        # No car and no obstacles or bot cars in the background (group 3 is hidden by default).
        self._renderer.update_scene(env.data, self._top_camera, scene_option=self._static_only)
        self._top_background = self._renderer.render().copy()
        self._top_projection = Projection.from_scene(self._renderer.scene, width, height)

    def before_step(self, env: DeepRacerEnv) -> None:
        if self._top_background is None:
            self._render_top_background(env)
        pose = env.car.pose(env.data)
        self._follow.lookat[:] = (pose.origin_x_m, pose.origin_y_m, 0.05)
        self._follow.azimuth = math.degrees(pose.yaw_rad)
        self._renderer.update_scene(env.data, self._follow, scene_option=self._car_visible)
        follow = self._renderer.render().copy()
        incar = cv2.resize(env.render(), None, fx=INCAR_SCALE, fy=INCAR_SCALE, interpolation=cv2.INTER_NEAREST)
        self._pending = {"camera-incar": incar, "camera-45degree": follow}
        self._pending_pose = (pose.origin_x_m, pose.origin_y_m, pose.yaw_rad)
        self._objects = tuple(env.object_poses)

    def on_step(self, record: StepRecord) -> None:
        if self._pending is None or self._pending_pose is None:
            raise RuntimeError("VideoRecorder.on_step without before_step")
        frames = self._pending
        frames["camera-topview"] = self._top_frame(*self._pending_pose, record)
        self._pending = None
        scale = self.options.height_px / 240.0
        _hud(frames["camera-45degree"], record, scale)
        _hud(frames["camera-topview"], record, scale)
        _hud(frames["camera-incar"], record, INCAR_SCALE * 120 / 240.0)
        for view in VIEWS:
            self._encoders[view].add(frames[view])

    def _top_frame(self, x_m: float, y_m: float, yaw_rad: float, record: StepRecord) -> np.ndarray:
        assert self._top_background is not None and self._top_projection is not None
        frame = self._top_background.copy()
        self._trail.append((float(record.row["X"]), float(record.row["Y"])))
        del self._trail[:-TRAIL_STEPS]
        if len(self._trail) > 1:
            trail = self._top_projection.to_pixels(np.array([(x, y, 0.0) for x, y in self._trail]))
            cv2.polylines(frame, [np.round(trail).astype(np.int32)], False, (0, 200, 255), 2, cv2.LINE_AA)
        for obj in self._objects:
            corners = np.round(self._top_projection.to_pixels(_object_outline(obj))).astype(np.int32)
            cv2.fillPoly(frame, [corners], OBJECT_RGB[obj.kind], cv2.LINE_AA)
            cv2.polylines(frame, [corners], True, (235, 235, 235), 1, cv2.LINE_AA)
        outline = self._top_projection.to_pixels(car_outline(x_m, y_m, yaw_rad))
        color = (230, 30, 30) if record.row["episode_status"] not in ("pause", "off_track") else (255, 140, 0)
        cv2.fillPoly(frame, [np.round(outline).astype(np.int32)], color, cv2.LINE_AA)
        return frame

    def close(self) -> None:
        for encoder in self._encoders.values():
            encoder.close()
        self._renderer.close()
