"""The car's 2-D LIDAR and DeepRacer's three ways of feeding it to the network (deepracer-simapp v5.3.3
`bundle/markov/sensors/constants.py`).

64 rays over ±2.61799 rad (300°) in the car's horizontal plane, 0.15–12 m, Gaussian noise σ = 0.01 m, 10 Hz
(the env runs at 15 Hz, so a scan is reused until the next one is due). Rays see geoms of group 0 (racer's walls,
which DeepRacer's LIDAR sees too) and group 2 (obstacles and bot cars, `objects/bodies.py`); the floor, the road and
its markings (group 1) and the car itself (group 3, and its body is excluded) are not seen. With DeepRacer's own
world meshes (`simapp_dir`) everything of the world is in group 1, so only the objects are seen.
"""

from __future__ import annotations

import math

import numpy as np

from racer.shared.sim.scene._mujoco import mujoco

NUM_RAYS = 64
MIN_ANGLE_RAD = -2.61799
MAX_ANGLE_RAD = 2.61799
MIN_RANGE_M = 0.15
MAX_RANGE_M = 12.0
NOISE_STD_M = 0.01
SCAN_PERIOD_S = 0.1
LIDAR_CLIP_HIGH_M = 1.0
"""`LIDAR` observations are clipped to [0.15, 1.0]."""
SECTOR_LIDAR_SECTORS = 8
SECTOR_LIDAR_CLIP_M = 0.5
VISIBLE_GROUPS = np.array([1, 0, 1, 0, 0, 0], dtype=np.uint8)


def sector_bits(ranges: np.ndarray, num_sectors: int, num_values: int, clipping_dist_m: float) -> np.ndarray:
    """One-hot distance bin per sector of the nearest return, the "nothing within reach" bin dropped.

    bin = floor(min(min_range, clip) / (clip / num_values)); bin == num_values means nothing detected.
    """
    per_sector = ranges.reshape(num_sectors, -1).min(axis=1)
    bins = np.floor(np.minimum(per_sector, clipping_dist_m) / (clipping_dist_m / num_values)).astype(np.int64)
    out = np.zeros((num_sectors, num_values), dtype=np.float32)
    hit = bins < num_values
    out[np.nonzero(hit)[0], bins[hit]] = 1.0
    return out.ravel()


class Lidar:
    """Casts the 64 rays from the `lidar` site with `mj_multiRay`."""

    def __init__(self, model: mujoco.MjModel, exclude_body: int) -> None:
        self._site = model.site("lidar").id
        angles = np.linspace(MIN_ANGLE_RAD, MAX_ANGLE_RAD, NUM_RAYS)
        self._local_dirs = np.stack([np.cos(angles), np.sin(angles), np.zeros(NUM_RAYS)], axis=1)
        self._exclude_body = exclude_body
        self._geomid = np.zeros(NUM_RAYS, dtype=np.int32)
        self._dist = np.zeros(NUM_RAYS, dtype=np.float64)
        self._last_scan = np.full(NUM_RAYS, math.inf)
        self._last_scan_time_s = -math.inf

    def reset(self) -> None:
        self._last_scan_time_s = -math.inf

    def scan(self, model: mujoco.MjModel, data: mujoco.MjData, rng: np.random.Generator) -> np.ndarray:
        """Ranges in metres (inf = no return), refreshed at 10 Hz of simulated time."""
        if data.time - self._last_scan_time_s < SCAN_PERIOD_S - 1e-9:
            return self._last_scan
        origin = data.site_xpos[self._site].copy()
        rotation = data.site_xmat[self._site].reshape(3, 3)
        directions = (self._local_dirs @ rotation.T).ravel()
        mujoco.mj_multiRay(
            model,
            data,
            origin,
            directions,
            VISIBLE_GROUPS,
            1,
            self._exclude_body,
            self._geomid,
            self._dist,
            None,
            NUM_RAYS,
            MAX_RANGE_M,
        )
        ranges = np.where(self._geomid >= 0, self._dist, math.inf)
        ranges = ranges + rng.normal(0.0, NOISE_STD_M, NUM_RAYS)
        ranges = np.where(ranges > MAX_RANGE_M, math.inf, np.maximum(ranges, MIN_RANGE_M))
        self._last_scan = ranges
        self._last_scan_time_s = data.time
        return ranges
