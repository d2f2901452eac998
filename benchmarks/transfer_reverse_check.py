"""`python -m benchmarks transfer --racer-model`: the reverse check. A racer model's greedy steering side (left /
straight / right) on DeepRacer's 92 Gazebo frames, and how often it agrees with each real checkpoint's; the same on
racer's own frames is the baseline."""

from __future__ import annotations

import json
from pathlib import Path

import click
import numpy as np
import torch

from benchmarks.gazebo_frames import GAZEBO_FRAMES, load_gazebo_frames, render_lap
from benchmarks.real_models import RealModel
from benchmarks.transfer_drive import greedy_action
from racer.shared.deepracer.model_metadata import ModelMetadata, parse_model_metadata
from racer.shared.policy.checkpoints import CheckpointStore
from racer.shared.sim.sensors.camera import rgb_to_y
from racer.shared.store import LocalStore

RACER_FRAME_POSES = 60
"""Centre-line poses of re:Invent 2018 rendered in racer for the reverse check's baseline."""


def steering_sides(model_metadata: ModelMetadata, network: torch.nn.Module, frames_grey: np.ndarray) -> np.ndarray:
    """-1 right, 0 straight, +1 left (DeepRacer's sign) of the greedy action on each frame."""
    sides = []
    for grey in frames_grey:
        action = greedy_action(network, model_metadata.camera_sensor, grey[:, :, None])
        sides.append(int(np.sign(model_metadata.discrete_actions[action].steering_angle_deg)))
    return np.asarray(sides)


def side_fractions(sides: np.ndarray) -> dict[str, float]:
    """The fraction of frames on which the greedy action steers left, goes straight, steers right."""
    return {
        name: round(float(np.mean(sides == value)), 3) for name, value in (("left", 1), ("straight", 0), ("right", -1))
    }


def open_racer_model(folder: Path) -> tuple[ModelMetadata, CheckpointStore]:
    """A racer model folder in racer's local store layout (racer-data/MODEL), with a discrete action space: its
    model_metadata and its checkpoints; a clear error otherwise."""
    metadata_path = folder / "model" / "model_metadata.json"
    if not metadata_path.is_file():
        raise click.ClickException(f"{metadata_path} is missing: --racer-model takes a racer model folder")
    metadata = parse_model_metadata(json.loads(metadata_path.read_text()), source=str(metadata_path))
    if metadata.is_continuous:
        raise click.ClickException(f"{folder}: steering sides compare discrete action spaces")
    return metadata, CheckpointStore(LocalStore(folder.parent), folder.name)


def reverse_check(racer_model: Path, real: list[RealModel], frames_grey: np.ndarray, racer_grey: np.ndarray) -> dict:
    """A racer model (a folder of racer's local store) on the Gazebo frames, against each real checkpoint; and the
    same comparison on racer's own frames (`racer_frames`), the baseline: how far two policies that both lap differ
    in style whatever the simulator (sign agreement there bounds what a simulator change can reach on the Gazebo
    frames)."""
    metadata, checkpoints = open_racer_model(racer_model)
    result: dict = {"model": str(racer_model), "checkpoints": {}}
    real_sides = {model.label: steering_sides(model.metadata, model.network, frames_grey) for model in real}
    real_on_racer = {model.label: steering_sides(model.metadata, model.network, racer_grey) for model in real}
    result["real_shares"] = {label: side_fractions(sides) for label, sides in real_sides.items()}
    result["real_shares_on_racer_frames"] = {label: side_fractions(sides) for label, sides in real_on_racer.items()}
    # The real run's own spread: how much two of its checkpoints differ is the scale for any racer model's figures.
    labels = sorted(real_sides)
    result["real_sign_agreement"] = {
        f"{first} vs {second}": {
            "gazebo_frames": round(float(np.mean(real_sides[first] == real_sides[second])), 3),
            "racer_frames": round(float(np.mean(real_on_racer[first] == real_on_racer[second])), 3),
        }
        for i, first in enumerate(labels)
        for second in labels[i + 1 :]
    }
    for name in checkpoints.names():
        network = checkpoints.load_policy(name)
        sides = steering_sides(metadata, network, frames_grey)
        ours = steering_sides(metadata, network, racer_grey)
        result["checkpoints"][name] = {
            "shares": side_fractions(sides),
            "sign_agreement": {label: round(float(np.mean(sides == other)), 3) for label, other in real_sides.items()},
            "racer_frames": {
                "shares": side_fractions(ours),
                "sign_agreement": {
                    label: round(float(np.mean(ours == other)), 3) for label, other in real_on_racer.items()
                },
            },
        }
    return result


def run_reverse_check(racer_model: Path, real: list[RealModel], data: Path, track: Path, world: str) -> dict:
    """`reverse_check` on DeepRacer's Gazebo frames (from `data`) and on racer's frames of `track` in `world`."""
    frames_rgb = load_gazebo_frames(data / GAZEBO_FRAMES)
    frames_grey = np.stack([rgb_to_y(frame) for frame in frames_rgb])
    rendered, _ = render_lap(track, world, RACER_FRAME_POSES, full_resolution=False)
    racer_grey = np.stack([rgb_to_y(frame) for frame in rendered])
    return reverse_check(racer_model, real, frames_grey, racer_grey)
