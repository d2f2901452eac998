"""DeepRacer's reference camera frames: the Gazebo episode's in-car frames (`frames/gazebo_reinvent_episode` in the
DeepRacer test data), the only real camera frames racer has. `python -m benchmarks transfer --racer-model` reads a racer
policy's steering on them and on racer's frames at the same poses (`racer.model_io.pose_frames`).
"""

from __future__ import annotations

from pathlib import Path

import click
import numpy as np
from PIL import Image

from racer.model_io.pose_frames import render_lap, render_poses

__all__ = ["GAZEBO_FRAMES", "load_gazebo_frames", "render_lap", "render_poses"]

GAZEBO_FRAMES = "frames/gazebo_reinvent_episode"
"""Where the Gazebo frames lie inside the DeepRacer test data folder."""


def load_gazebo_frames(folder: Path) -> np.ndarray:
    """(N, 120, 160, 3) uint8 RGB frames of the Gazebo episode, in file order; a clear error when missing."""
    files = sorted(folder.glob("*.png"))
    if not files:
        raise click.ClickException(
            f"no Gazebo frames (*.png) in {folder}: expected the folder {GAZEBO_FRAMES} of the DeepRacer test data"
        )
    frames = []
    for path in files:
        image = np.asarray(Image.open(path).convert("RGB"))
        if image.shape != (120, 160, 3):
            raise click.ClickException(f"{path}: expected a 160x120 frame, got {image.shape[1]}x{image.shape[0]}")
        frames.append(image)
    return np.stack(frames)
