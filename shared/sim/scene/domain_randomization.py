"""Per-episode randomisation of what the camera sees: DeepRacer's light randomisation, and racer's for the real car.

`ENABLE_DOMAIN_RANDOMIZATION` (the SimApp's `LightRandomizer`, applied to every light at each episode reset):
each light gets a diffuse colour drawn uniformly per channel from [0, 1], a specular half of it, and constant,
linear and quadratic attenuation each drawn from [0, 1] (a directional light ignores attenuation, in Gazebo as in
MuJoCo). racer's lights are in MuJoCo units, so the colours are scaled by `world_look.LIGHT_SCALE`. With obstacles
on the track, each static obstacle also gets one colour drawn uniformly per channel from [0, 1] for all its parts
(the SimApp's `ModelVisualRandomizer`, model level; bot cars driving their lane keep their colour).

racer's car randomisation (`RACER_CAR_RANDOMIZATION`, off by default) goes further for the physical car, whose
camera sees other colours, light, noise and mounting than any simulator: per episode, a tint and brightness of every
material (road, field, lines, walls), a camera blur and noise level, and a small camera pose jitter; the noise is fresh every frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from racer.shared.sim.objects.bodies import obstacle_materials
from racer.shared.sim.scene import world_look
from racer.shared.sim.scene._mujoco import mujoco


@dataclass(frozen=True)
class CarRandomizationRanges:
    """Ranges of racer's car randomisation (each drawn uniformly per episode)."""

    tint: float = 0.12
    """Each colour channel of the materials is scaled by 1 ± this."""
    brightness: tuple[float, float] = (0.6, 1.4)
    blur_sigma_px: tuple[float, float] = (0.0, 1.0)
    noise_std: tuple[float, float] = (0.0, 8.0)
    """Standard deviation of per-pixel Gaussian noise, in grey levels of the 0-255 RGB frame."""
    camera_shift_m: float = 0.01
    camera_tilt_rad: float = math.radians(3.0)


@dataclass(frozen=True)
class FrameEffects:
    """The blur and noise of one episode's frames."""

    blur_sigma_px: float
    noise_std: float


class SceneRandomizer:
    """Changes one compiled model's lights, materials and cameras between episodes (no recompilation)."""

    def __init__(self, model: mujoco.MjModel, lights: bool, car: bool, ranges: CarRandomizationRanges | None = None):
        self.lights = lights
        self.car = car
        self.ranges = ranges or CarRandomizationRanges()
        self._light_diffuse = model.light_diffuse.copy()
        self._light_specular = model.light_specular.copy()
        self._light_attenuation = model.light_attenuation.copy()
        self._materials = np.arange(model.nmat)
        self._material_rgba = model.mat_rgba[self._materials].copy()
        self._camera_pos = model.cam_pos.copy()
        self._camera_quat = model.cam_quat.copy()
        self._obstacle_materials = obstacle_materials(model)
        self.effects = FrameEffects(0.0, 0.0)

    @property
    def enabled(self) -> bool:
        return self.lights or self.car

    def randomize(self, model: mujoco.MjModel, rng: np.random.Generator) -> None:
        """Draw this episode's scene (call at reset, before the first frame)."""
        if self.lights:
            count = model.nlight
            diffuse = world_look.LIGHT_SCALE * rng.uniform(0.0, 1.0, (count, 3))
            model.light_diffuse[:] = diffuse
            model.light_specular[:] = diffuse / 2
            model.light_attenuation[:] = rng.uniform(0.0, 1.0, (count, 3))
        if self.car:
            r = self.ranges
            tint = rng.uniform(1.0 - r.tint, 1.0 + r.tint, 3) * rng.uniform(*r.brightness)
            rgba = self._material_rgba.copy()
            rgba[:, :3] = np.clip(rgba[:, :3] * tint, 0.0, None)
            model.mat_rgba[self._materials] = rgba
            shift = rng.uniform(-r.camera_shift_m, r.camera_shift_m, self._camera_pos.shape)
            model.cam_pos[:] = self._camera_pos + shift
            for index, quat in enumerate(self._camera_quat):
                axis = rng.normal(size=3)
                angle = rng.uniform(0.0, r.camera_tilt_rad)
                jitter = np.empty(4)
                mujoco.mju_axisAngle2Quat(jitter, axis / np.linalg.norm(axis), angle)
                rotated = np.empty(4)
                mujoco.mju_mulQuat(rotated, quat, jitter)
                model.cam_quat[index] = rotated
            self.effects = FrameEffects(rng.uniform(*r.blur_sigma_px), rng.uniform(*r.noise_std))
        if self.lights:
            for materials in self._obstacle_materials:
                model.mat_rgba[materials, :3] = rng.uniform(0.0, 1.0, 3)

    def restore(self, model: mujoco.MjModel) -> None:
        """Put back the world's own lights, materials and cameras."""
        model.light_diffuse[:] = self._light_diffuse
        model.light_specular[:] = self._light_specular
        model.light_attenuation[:] = self._light_attenuation
        model.mat_rgba[self._materials] = self._material_rgba
        model.cam_pos[:] = self._camera_pos
        model.cam_quat[:] = self._camera_quat
        self.effects = FrameEffects(0.0, 0.0)

    def process_frame(self, rgb: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """The episode's blur and fresh noise on an RGB frame (a new array; the input is not changed)."""
        effects = self.effects
        if effects.blur_sigma_px > 0.05:
            rgb = cv2.GaussianBlur(rgb, (0, 0), effects.blur_sigma_px)
        if effects.noise_std > 0.0:
            # Luminance noise (one value per pixel for all three channels): the policy sees grey frames.
            noise = rng.standard_normal((*rgb.shape[:2], 1), dtype=np.float32) * np.float32(effects.noise_std)
            rgb = np.clip(rgb + noise, 0, 255).astype(np.uint8)
        return rgb
