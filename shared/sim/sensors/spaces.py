"""The env's Gymnasium spaces from `model_metadata`, and what goes in and out of them: the decoded action and the
LIDAR part of the observation (deepracer-simapp v5.3.3 `bundle/markov/sensors/constants.py`,
`bundle/markov/environments/`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from gymnasium import spaces

from racer.shared.deepracer.model_metadata import LidarConfig, ModelMetadata
from racer.shared.deepracer.simtrace import format_continuous_action
from racer.shared.sim.sensors import lidar as lidar_sensor


@dataclass(frozen=True, slots=True)
class ChosenAction:
    """The action as the simtrace and the reward params see it: unclipped, before the car's limits."""

    steering_deg: float
    speed_mps: float
    simtrace_field: int | str
    """The simtrace's `action` column: the discrete index, or DeepRacer's "[steer speed]" text."""


def action_space(metadata: ModelMetadata) -> spaces.Space:
    if metadata.is_continuous:
        return spaces.Box(-1.0, 1.0, shape=(2,), dtype=np.float32)
    return spaces.Discrete(len(metadata.discrete_actions))


def decode_action(metadata: ModelMetadata, action: Any) -> ChosenAction:
    """The agent's action as steering and speed: a discrete index, or [steering, speed] scaled from [-1, 1]."""
    if metadata.is_continuous:
        values = np.asarray(action, dtype=np.float64).reshape(-1)
        if values.shape != (2,):
            raise ValueError(f"a continuous action is [steering, speed] in [-1, 1], got {action!r}")
        steering, speed = metadata.scale_continuous_action(values)
        return ChosenAction(steering, speed, format_continuous_action((steering, speed)))
    index = int(action)
    if not 0 <= index < len(metadata.discrete_actions):
        raise ValueError(f"action index {index} is outside 0..{len(metadata.discrete_actions) - 1}")
    chosen = metadata.discrete_actions[index]
    return ChosenAction(chosen.steering_angle_deg, chosen.speed_mps, index)


def observation_space(metadata: ModelMetadata, height_px: int, width_px: int) -> spaces.Dict:
    """One entry per sensor, keyed by its `sensor` name: the grey camera frame (two for stereo) and the LIDAR."""
    camera_key, lidar_key = metadata.camera_sensor, metadata.lidar_sensor
    channels = 2 if camera_key == "STEREO_CAMERAS" else 1
    entries: dict[str, spaces.Space] = {
        camera_key: spaces.Box(0, 255, shape=(height_px, width_px, channels), dtype=np.uint8)
    }
    if lidar_key == "LIDAR":
        entries["LIDAR"] = spaces.Box(
            lidar_sensor.MIN_RANGE_M,
            lidar_sensor.LIDAR_CLIP_HIGH_M,
            shape=(lidar_sensor.NUM_RAYS,),
            dtype=np.float32,
        )
    elif lidar_key == "SECTOR_LIDAR":
        entries["SECTOR_LIDAR"] = spaces.Box(0.0, 1.0, shape=(lidar_sensor.SECTOR_LIDAR_SECTORS,), dtype=np.float32)
    elif lidar_key == "DISCRETIZED_SECTOR_LIDAR":
        lc = metadata.lidar_config
        entries["DISCRETIZED_SECTOR_LIDAR"] = spaces.Box(
            0.0, 1.0, shape=(lc.num_sectors * lc.num_values_per_sector,), dtype=np.float32
        )
    return spaces.Dict(entries)


def lidar_observation(sensor: str, lc: LidarConfig, ranges: np.ndarray) -> np.ndarray:
    """A scan's ranges as the LIDAR `sensor` feeds them to the network (`lc`: DISCRETIZED_SECTOR_LIDAR's bins)."""
    if sensor == "LIDAR":
        return np.clip(ranges, lidar_sensor.MIN_RANGE_M, lidar_sensor.LIDAR_CLIP_HIGH_M).astype(np.float32)
    if sensor == "SECTOR_LIDAR":
        return lidar_sensor.sector_bits(ranges, lidar_sensor.SECTOR_LIDAR_SECTORS, 1, lidar_sensor.SECTOR_LIDAR_CLIP_M)
    return lidar_sensor.sector_bits(ranges, lc.num_sectors, lc.num_values_per_sector, lc.clipping_dist_m)
