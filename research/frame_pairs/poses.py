"""The Gazebo frames' car poses on re:Invent 2018, fitted from their painted lines (`python -m research.frame_pairs
--save-poses`): racer's frames at these poses show what the Gazebo frames show."""

from __future__ import annotations

import json
from pathlib import Path

FITTED_POSES = Path(__file__).with_name("gazebo_frame_poses.json")


def load_fitted_poses(path: Path = FITTED_POSES) -> list[tuple[float, float, float]]:
    """(x, y, yaw) of the car's origin per Gazebo frame, in file order."""
    document = json.loads(path.read_text())
    return [(pose["x_m"], pose["y_m"], pose["yaw_rad"]) for pose in document["poses"]]
