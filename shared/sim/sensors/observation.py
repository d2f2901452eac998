"""What the env's sensors return: the cameras a model's `sensor` list asks for, their frames (the single camera's
frame starts rendering before the step's reward work and is finished after it), the car randomisation's blur and
noise, DeepRacer's grey or stereo conversion, and the LIDAR scan."""

from __future__ import annotations

import numpy as np

from racer.shared.deepracer.model_metadata import ModelMetadata
from racer.shared.sim.car.vehicle import STEREO_HALF_BASELINE_M
from racer.shared.sim.config import EnvConfig
from racer.shared.sim.objects.bodies import OBJECT_GEOM_GROUP
from racer.shared.sim.scene._mujoco import mujoco
from racer.shared.sim.scene.domain_randomization import SceneRandomizer
from racer.shared.sim.sensors import lidar as lidar_sensor
from racer.shared.sim.sensors.camera import (
    CENTER_CAMERA,
    LEFT_CAMERA,
    RIGHT_CAMERA,
    CameraRenderer,
    GrayConverter,
    rgb_to_l,
)
from racer.shared.sim.sensors.spaces import lidar_observation


def scene_cameras(camera_key: str, with_front_view: bool) -> tuple[tuple[tuple[str, float], ...], tuple[str, ...]]:
    """(cameras the scene mounts, as (name, lateral offset m); cameras an observation renders). `with_front_view`
    (`render_mode="rgb_array"`) mounts the front camera too."""
    if camera_key == "STEREO_CAMERAS":
        cameras = ((LEFT_CAMERA, STEREO_HALF_BASELINE_M), (RIGHT_CAMERA, -STEREO_HALF_BASELINE_M))
        rendered: tuple[str, ...] = (LEFT_CAMERA, RIGHT_CAMERA)
    elif camera_key == "LEFT_CAMERA":
        cameras, rendered = ((LEFT_CAMERA, STEREO_HALF_BASELINE_M),), (LEFT_CAMERA,)
    else:
        cameras, rendered = ((CENTER_CAMERA, 0.0),), (CENTER_CAMERA,)
    if with_front_view and CENTER_CAMERA not in dict(cameras):
        cameras = cameras + ((CENTER_CAMERA, 0.0),)
    return cameras, rendered


class Observer:
    """The env's sensors on one compiled scene: `start` then `finish` make one observation dict."""

    def __init__(
        self,
        model: mujoco.MjModel,
        car_body_id: int,
        config: EnvConfig,
        metadata: ModelMetadata,
        randomizer: SceneRandomizer,
        rendered_cameras: tuple[str, ...],
        keep_front_rgb: bool,
    ) -> None:
        self._model = model
        self._metadata = metadata
        self._randomizer = randomizer
        self._camera_key = metadata.camera_sensor
        self._lidar_key = metadata.lidar_sensor
        self._stereo = self._camera_key == "STEREO_CAMERAS"
        self._rendered_cameras = rendered_cameras
        self._keep_front_rgb = keep_front_rgb and rendered_cameras[0] == CENTER_CAMERA
        self.camera = CameraRenderer(
            model,
            config.image_width_px,
            config.image_height_px,
            config.render_full_resolution,
            front_groups=(OBJECT_GEOM_GROUP,) if config.challenge.has_objects else (),
        )
        self._gray = GrayConverter((config.image_height_px, config.image_width_px))
        self.lidar = lidar_sensor.Lidar(model, car_body_id) if self._lidar_key else None
        self._last_rgb: np.ndarray | None = None

    def start(self, data: mujoco.MjData) -> None:
        """Begin rendering the single camera's frame (stereo renders both eyes in `finish`)."""
        if not self._stereo:
            self.camera.start(data, self._rendered_cameras[0])

    def finish(
        self, data: mujoco.MjData, np_random: np.random.Generator, scene_rng: np.random.Generator
    ) -> dict[str, np.ndarray]:
        """The observation: the camera image (after `start`) and the LIDAR scan (`np_random` draws its noise)."""
        if self._stereo:
            left = rgb_to_l(self._camera_frame(self.camera.rgb(data, LEFT_CAMERA), scene_rng))
            right = rgb_to_l(self._camera_frame(self.camera.rgb(data, RIGHT_CAMERA), scene_rng))
            image = np.stack((left, right), axis=-1)
        else:
            rgb = self._camera_frame(self.camera.finish(), scene_rng)
            if self._keep_front_rgb:
                self._last_rgb = rgb.copy()
            image = self._gray.to_y(rgb)[:, :, None]
        observation = {self._camera_key: image}
        if self.lidar is not None:
            ranges = self.lidar.scan(self._model, data, np_random)
            observation[self._lidar_key] = lidar_observation(self._lidar_key, self._metadata.lidar_config, ranges)
        return observation

    def _camera_frame(self, rgb: np.ndarray, scene_rng: np.random.Generator) -> np.ndarray:
        """The rendered frame with the episode's camera blur and noise (car randomisation only)."""
        return self._randomizer.process_frame(rgb, scene_rng) if self._randomizer.car else rgb

    def front_rgb(self, data: mujoco.MjData) -> np.ndarray:
        """The front camera's RGB frame of the latest observation (rendered now when the observation has none)."""
        if self._last_rgb is None:
            return self.camera.rgb(data, CENTER_CAMERA).copy()
        return self._last_rgb

    def close(self) -> None:
        self.camera.close()
