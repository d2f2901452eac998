"""One top-view video of a whole multi-car race (HEAD_TO_MODEL, F1): every car on one picture of the track.

Each car's own videos show the race from that car (`video.py`); this one shows the field. The track is rendered once
from above, as a car's top view is (`video.top_view_camera`, same projection), and every tick the cars are drawn
onto it with OpenCV where the race loop's snapshot has them (the poses the crash test judges), each in its own
colour with its grid number, a legend of the names below. A car serving a penalty (not collidable) is drawn as an
outline only; a parked car (F1) is not drawn. One frame per tick at 15 fps, so it plays in simulated real time.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import cv2
import numpy as np

from racer.evaluation_worker.config import VideoOptions
from racer.evaluation_worker.video import Mp4Encoder, Projection, car_outline, top_view_camera
from racer.shared.sim.env import DeepRacerEnv
from racer.shared.sim.objects.bodies import OBJECT_GEOM_GROUP
from racer.shared.sim.objects.peer_cars import PeerState
from racer.shared.sim.scene._mujoco import mujoco

ALL_CARS_VIEW = "camera-allcars"
"""`racer evaluate --opponent`: the view's folder beside the first car's videos (`<run>/camera-allcars/0-video.mp4`)."""
CAR_RGB = (
    (230, 30, 30),
    (30, 90, 230),
    (20, 170, 60),
    (240, 150, 0),
    (150, 40, 200),
    (0, 180, 200),
    (200, 60, 140),
    (110, 110, 110),
)
"""One colour per grid place (then again from the first): red, blue, green, orange, purple, teal, pink, grey."""
_FONT = cv2.FONT_HERSHEY_SIMPLEX


def car_colour(index: int) -> tuple[int, int, int]:
    return CAR_RGB[index % len(CAR_RGB)]


class AllCarsTopView:
    """Call `add(snapshot, sim_time_s)` once per tick of the race loop, then `close()`."""

    def __init__(self, env: DeepRacerEnv, path: Path, names: Sequence[str], options: VideoOptions) -> None:
        self.path = path
        self.names = tuple(names)
        self._env = env
        self._width_px, self._height_px = options.width_px, options.height_px
        self._camera = top_view_camera(env, self._width_px, self._height_px)
        self._background: np.ndarray | None = None
        self._projection: Projection | None = None
        path.unlink(missing_ok=True)  # a file of an earlier run must not pass for this one
        self._encoder = Mp4Encoder(path)

    @property
    def frames(self) -> int:
        return self._encoder.frames

    def _render_background(self) -> None:
        """The track without cars or objects, once: after the grid is set, the static geoms have their poses."""
        static_only = mujoco.MjvOption()
        static_only.geomgroup[OBJECT_GEOM_GROUP] = 0
        with mujoco.Renderer(self._env.model, height=self._height_px, width=self._width_px) as renderer:
            renderer.update_scene(self._env.data, self._camera, scene_option=static_only)
            self._background = renderer.render().copy()
            self._projection = Projection.from_scene(renderer.scene, self._width_px, self._height_px)

    def add(self, snapshot: Sequence[PeerState], sim_time_s: float) -> None:
        if self._background is None:
            self._render_background()
        assert self._background is not None and self._projection is not None
        frame = self._background.copy()
        scale = self._height_px / 240.0
        for car in snapshot:
            if not car.on_track:
                continue
            outline = np.round(self._projection.to_pixels(car_outline(car.x_m, car.y_m, car.yaw_rad)))
            corners = outline.astype(np.int32)
            if car.collidable:
                cv2.fillPoly(frame, [corners], car_colour(car.index), cv2.LINE_AA)
            else:
                cv2.polylines(frame, [corners], True, car_colour(car.index), 2, cv2.LINE_AA)
            u, v = (int(value) for value in outline.mean(axis=0))
            _text(frame, str(car.index + 1), (u + 6, v - 6), 0.4 * scale, (255, 255, 255))
        _text(frame, f"t {sim_time_s:6.2f}s", (4, int(14 * scale) + 2), 0.4 * scale, (255, 255, 255))
        self._legend(frame, scale)
        self._encoder.add(frame)

    def _legend(self, frame: np.ndarray, scale: float) -> None:
        """Grid number, colour and name of every car, in rows along the bottom."""
        row_px = int(12 * scale) + 2
        x, y = 4, self._height_px - 4 - row_px * ((len(self.names) + 1) // 2 - 1)
        for index, name in enumerate(self.names):
            left = x + (index % 2) * (self._width_px // 2)
            top = y + (index // 2) * row_px
            cv2.rectangle(frame, (left, top - row_px + 4), (left + row_px - 4, top), car_colour(index), -1)
            _text(frame, f"{index + 1} {name}", (left + row_px, top), 0.35 * scale, (255, 255, 255))

    def close(self) -> None:
        self._encoder.close()


def _text(frame: np.ndarray, text: str, origin: tuple[int, int], size: float, rgb: tuple[int, int, int]) -> None:
    thickness = max(1, int(round(size * 3)))
    cv2.putText(frame, text, origin, _FONT, size, (0, 0, 0), thickness + 2, cv2.LINE_AA)
    cv2.putText(frame, text, origin, _FONT, size, rgb, thickness, cv2.LINE_AA)
