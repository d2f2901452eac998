"""racer's camera frames at chosen poses, drawn with the camera of the car that recorded DeepRacer's Gazebo frames.

`racer model explain --racer-frames` draws these around a lap; the transfer benchmark reads a racer policy's steering on
them beside the Gazebo episode's frames (`benchmarks/gazebo_frames.py`), so both sets show the same view.
"""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path

import numpy as np

from racer.shared.sim.config import DEFAULT_MODEL_METADATA, EnvConfig
from racer.shared.sim.env import DeepRacerEnv
from racer.shared.sim.sensors.camera import CENTER_CAMERA, CameraRenderer

GAZEBO_EPISODE_SIMAPP_VERSION = 3.0
"""The camera mount of the car that recorded the Gazebo frames: SimApp version >= 3, (0.145, 0, 0.130) m. Their lines
fit re:Invent 2018 at a median 1.84 cm with it against 3.23 cm with the older (0.2, 0, 0.164) m mount of version < 3
(research/frame_pairs/README.md)."""
GAZEBO_EPISODE_GENERATION = "2019"
"""The frames are Gazebo classic's of 2019: racer draws them in that generation's look (walls, lights)."""


def gazebo_episode_config(
    route: str | Path, world: str, full_resolution: bool, simapp_dir: Path | None = None
) -> EnvConfig:
    """An env with the camera of the car that recorded the Gazebo frames (`GAZEBO_EPISODE_SIMAPP_VERSION`), in the
    generation they were recorded in (`2019`)."""
    metadata = dataclasses.replace(DEFAULT_MODEL_METADATA, version=GAZEBO_EPISODE_SIMAPP_VERSION)
    return EnvConfig(
        track=route,
        world=world,
        model_metadata=metadata,
        render_full_resolution=full_resolution,
        simapp_dir=simapp_dir,
        generation=GAZEBO_EPISODE_GENERATION,
    )


def render_lap(
    route: str | Path, world: str, poses: int, full_resolution: bool, simapp_dir: Path | None = None
) -> tuple[np.ndarray, float]:
    """RGB frames at `poses` evenly spread centre-line poses of `route` (a track name or route file), and the mean
    milliseconds per frame."""
    return render_poses(route, world, _centre_line_poses(route, poses), full_resolution, simapp_dir)


def _centre_line_poses(route: str | Path, poses: int) -> list[tuple[float, float, float]]:
    from racer.shared.sim.tracks.track import Track

    track = Track.load(route)
    return [track.pose_at(float(ndist), "center") for ndist in np.arange(poses) / poses]


def render_poses(
    route: str | Path,
    world: str,
    poses: list[tuple[float, float, float]],
    full_resolution: bool,
    simapp_dir: Path | None = None,
) -> tuple[np.ndarray, float]:
    """RGB frames with the car (origin) at each pose (x, y, yaw), and the mean milliseconds per frame."""
    env = DeepRacerEnv(gazebo_episode_config(route, world, full_resolution, simapp_dir))
    try:
        env.reset(seed=0)
        renderer: CameraRenderer = env._camera  # the env's own renderer: the path training uses
        frames, elapsed_s = [], 0.0
        for pose in poses:
            env.teleport(*pose)
            start = time.perf_counter()
            renderer.start(env.data, CENTER_CAMERA)
            frame = renderer.finish()
            elapsed_s += time.perf_counter() - start
            frames.append(frame.copy())
        return np.stack(frames), 1e3 * elapsed_s / max(len(poses), 1)
    finally:
        env.close()
