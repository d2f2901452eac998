"""DeepRacer's reference camera frames and racer's frames at the same poses: the Gazebo episode's in-car frames
(`frames/gazebo_reinvent_episode` in the shared deepracer-data), their grey-level statistics and distance, and
racer's front camera rendered at evenly spread centre-line poses of the re:Invent 2018 lap, or at the Gazebo frames'
own poses (fitted from their lines by `racer bench frame-pairs`, stored in `gazebo_frame_poses.json`). Used by
`racer bench camera`, `racer bench transfer` and `racer model explain --racer-frames`.
"""

from __future__ import annotations

import dataclasses
import json
import time
from dataclasses import dataclass
from pathlib import Path

import click
import numpy as np
from PIL import Image

from racer.shared.sim.camera import CENTER_CAMERA, CameraRenderer
from racer.shared.sim.config import DEFAULT_MODEL_METADATA, EnvConfig
from racer.shared.sim.env import DeepRacerEnv

DATA_DIR = Path(__file__).resolve().parents[2].parent / "shared" / "deepracer-data"
"""The shared DeepRacer data folder next to the repository (routes and Gazebo frames)."""
GAZEBO_FRAMES = "frames/gazebo_reinvent_episode"
ROUTE = "routes/reinvent_base.npy"
UPPER_ROWS = slice(0, 40)
LOWER_ROWS = slice(60, 120)
GAZEBO_EPISODE_SIMAPP_VERSION = 3.0
"""The camera mount of the car that recorded the Gazebo frames: SimApp version >= 3, (0.145, 0, 0.130) m. Their lines
fit re:Invent 2018 at a median 1.84 cm with it against 3.23 cm with the older (0.2, 0, 0.164) m mount of version < 3
(`racer bench frame-pairs --camera-height`, 2026-11-27); until then this was 2.0, a guess from the episode's year."""


@dataclass(frozen=True)
class FrameStats:
    """Grey-level statistics of a set of 160x120 frames."""

    histogram: np.ndarray
    lower_half_mean: float
    upper_third_mean: float


def frame_stats(gray_frames: np.ndarray) -> FrameStats:
    """(N, 120, 160) uint8 grey frames -> normalised histogram and region means."""
    histogram = np.bincount(gray_frames.ravel(), minlength=256).astype(np.float64)
    return FrameStats(
        histogram / histogram.sum(),
        float(gray_frames[:, LOWER_ROWS].mean()),
        float(gray_frames[:, UPPER_ROWS].mean()),
    )


def histogram_emd(a: np.ndarray, b: np.ndarray) -> float:
    """Earth-mover distance between two normalised 256-bin histograms, in grey levels."""
    return float(np.abs(np.cumsum(a) - np.cumsum(b)).sum())


PAIRED_BANDS = ((0, 40), (40, 80), (80, 120))
"""Image rows compared on the pairs: above the horizon (walls), the far field and road, the near road."""


def paired_grey_stats(ours_gray: np.ndarray, gazebo_gray: np.ndarray) -> dict:
    """racer's grey frames against the Gazebo frames of the same poses (the same views, so only the look differs):
    histogram distance of the two sets, mean absolute difference per pixel, mean grey per band (racer, Gazebo)."""
    if ours_gray.shape != gazebo_gray.shape:
        raise ValueError(f"{len(ours_gray)} racer frames for {len(gazebo_gray)} Gazebo frames")
    return {
        "histogram_emd": round(histogram_emd(frame_stats(ours_gray).histogram, frame_stats(gazebo_gray).histogram), 2),
        "mean_abs_grey_difference": round(float(np.abs(ours_gray.astype(int) - gazebo_gray.astype(int)).mean()), 1),
        "band_means_racer_vs_gazebo": {
            f"rows {top}-{bottom}": [
                round(float(ours_gray[:, top:bottom].mean()), 1),
                round(float(gazebo_gray[:, top:bottom].mean()), 1),
            ]
            for top, bottom in PAIRED_BANDS
        },
    }


def load_gazebo_frames(folder: Path) -> np.ndarray:
    """(N, 120, 160, 3) uint8 RGB frames of the Gazebo episode, in file order; a clear error when missing."""
    files = sorted(folder.glob("*.png"))
    if not files:
        raise click.ClickException(f"no Gazebo frames (*.png) in {folder}; pass --data DIR (the shared deepracer-data)")
    frames = []
    for path in files:
        image = np.asarray(Image.open(path).convert("RGB"))
        if image.shape != (120, 160, 3):
            raise click.ClickException(f"{path}: expected a 160x120 frame, got {image.shape[1]}x{image.shape[0]}")
        frames.append(image)
    return np.stack(frames)


def gazebo_episode_config(route: Path, world: str, full_resolution: bool, simapp_dir: Path | None = None) -> EnvConfig:
    """An env with the camera of the car that recorded the Gazebo frames (`GAZEBO_EPISODE_SIMAPP_VERSION`)."""
    metadata = dataclasses.replace(DEFAULT_MODEL_METADATA, version=GAZEBO_EPISODE_SIMAPP_VERSION)
    return EnvConfig(
        track=route, world=world, model_metadata=metadata, render_full_resolution=full_resolution, simapp_dir=simapp_dir
    )


def render_lap(
    route: Path, world: str, poses: int, full_resolution: bool, simapp_dir: Path | None = None
) -> tuple[np.ndarray, float]:
    """RGB frames at `poses` evenly spread centre-line poses, and the mean milliseconds per frame."""
    return render_poses(route, world, _centre_line_poses(route, poses), full_resolution, simapp_dir)


def _centre_line_poses(route: Path, poses: int) -> list[tuple[float, float, float]]:
    from racer.shared.sim.track import Track

    track = Track.load(route)
    return [track.pose_at(float(ndist), "center") for ndist in np.arange(poses) / poses]


def render_poses(
    route: Path,
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


FITTED_POSES = Path(__file__).with_name("gazebo_frame_poses.json")
"""The Gazebo frames' car poses on re:Invent 2018, fitted from their painted lines (`racer bench frame-pairs
--save-poses`): racer's frames at these poses show what the Gazebo frames show."""


def load_fitted_poses(path: Path = FITTED_POSES) -> list[tuple[float, float, float]]:
    document = json.loads(path.read_text())
    return [(pose["x_m"], pose["y_m"], pose["yaw_rad"]) for pose in document["poses"]]
