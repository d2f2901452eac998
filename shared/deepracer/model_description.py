"""What a `model_metadata.json` describes, in memory: a model's sensors, network, training algorithm, SimApp
version and action space (`ModelMetadata` and its parts), and how a continuous action is scaled onto its ranges.
Reading, checking and writing the file: `model_metadata.py`."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

CAMERA_SENSORS: tuple[str, ...] = ("FRONT_FACING_CAMERA", "STEREO_CAMERAS", "LEFT_CAMERA", "observation")
LIDAR_SENSORS: tuple[str, ...] = ("LIDAR", "SECTOR_LIDAR", "DISCRETIZED_SECTOR_LIDAR")
SENSOR_NAMES: tuple[str, ...] = CAMERA_SENSORS + LIDAR_SENSORS


@dataclass(frozen=True)
class DiscreteAction:
    steering_angle_deg: float
    """Positive turns left, negative turns right."""
    speed_mps: float


@dataclass(frozen=True)
class ContinuousActionSpace:
    steering_angle_low_deg: float
    steering_angle_high_deg: float
    speed_low_mps: float
    speed_high_mps: float


@dataclass(frozen=True)
class LidarConfig:
    """Only used by DISCRETIZED_SECTOR_LIDAR; the SimApp defaults when `lidar_config` is absent."""

    num_sectors: int = 8
    num_values_per_sector: int = 8
    clipping_dist_m: float = 2.0


@dataclass(frozen=True)
class ModelMetadata:
    action_space_type: str
    """`discrete` or `continuous`."""
    discrete_actions: tuple[DiscreteAction, ...]
    """In action-index order; empty when continuous."""
    continuous_action_space: ContinuousActionSpace | None
    sensors: tuple[str, ...]
    neural_network: str
    training_algorithm: str
    """`clipped_ppo` or `sac`."""
    version: float
    """SimApp version of the model (1.0 ... 6.0); physics details depend on it."""
    lidar_config: LidarConfig = LidarConfig()

    @property
    def is_continuous(self) -> bool:
        return self.action_space_type == "continuous"

    @property
    def num_actions(self) -> int:
        """Policy output size: number of discrete actions, or 2 (steering, speed) when continuous."""
        return len(self.discrete_actions) if not self.is_continuous else 2

    @property
    def camera_sensor(self) -> str:
        return next(sensor for sensor in self.sensors if sensor in CAMERA_SENSORS)

    @property
    def lidar_sensor(self) -> str | None:
        return next((sensor for sensor in self.sensors if sensor in LIDAR_SENSORS), None)

    def scale_continuous_action(self, network_action: Sequence[float]) -> tuple[float, float]:
        """Map a network output [steering, speed] in [-1, 1] to (steering_deg, speed_mps), as the SimApp env does.

        Each value is clipped to [-1, 1] first, then mapped linearly onto [low, high] of its dimension.
        """
        space = self.continuous_action_space
        if space is None:
            raise ValueError("scale_continuous_action needs a continuous action space; this model is discrete")
        values = [float(value) for value in network_action]
        if len(values) != 2:
            raise ValueError(f"a continuous action has 2 values [steering, speed], got {len(values)}")
        if not all(math.isfinite(value) for value in values):
            raise ValueError(f"continuous action contains NaN or infinity: {values}")
        steering, speed = (min(1.0, max(-1.0, value)) for value in values)
        return (
            _rescale(steering, space.steering_angle_low_deg, space.steering_angle_high_deg),
            _rescale(speed, space.speed_low_mps, space.speed_high_mps),
        )


def _rescale(value: float, low: float, high: float) -> float:
    return low + (value + 1.0) * 0.5 * (high - low)
