"""Where a run's static obstacles stood, from its params yaml, for the track maps.

The obstacle keys (`OBJECT_POSITIONS`, `NUMBER_OF_OBSTACLES`, ...) are read as the env reads them
(`ChallengeConfig.from_training_params`) and placed by the env's own placement (`obstacles.place_obstacles`), so the map
shows the boxes where the car met them. Randomised layouts change every episode and are not drawn; bot cars move
and are not drawn either (their crashes are still on the maps).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import yaml

from racer.shared.sim.objects.challenge import ChallengeConfig
from racer.shared.sim.objects.obstacles import place_obstacles
from racer.shared.sim.objects.poses import ObjectPose
from racer.shared.sim.tracks.track import Track

_TRAINING_PARAMS = re.compile(r"training_params(?:_(\d+))?\.ya?ml$")


@dataclass(frozen=True)
class ObstacleLayout:
    race_type: str = "TIME_TRIAL"
    obstacles: tuple[ObjectPose, ...] = ()
    """Static obstacles in the route's own direction (empty when there are none or they were randomised)."""
    notes: tuple[str, ...] = field(default=())


def _first_params(params_yaml: dict[str, bytes]) -> tuple[str, dict] | None:
    """Worker 0's training params (the lowest worker number), else the first evaluation params file."""
    parsed: list[tuple[int, str, dict]] = []
    for name, data in params_yaml.items():
        try:
            params = yaml.safe_load(data)
        except yaml.YAMLError:
            continue  # racer.analysis.run_track.run_tracks already warned about it
        if not isinstance(params, dict):
            continue
        worker = _TRAINING_PARAMS.search(Path(name).name)
        rank = int(worker.group(1) or 0) if worker else 1_000_000
        parsed.append((rank, name, params))
    if not parsed:
        return None
    _rank, name, params = min(parsed, key=lambda item: (item[0], item[1]))
    return name, params


def obstacle_layout(params_yaml: dict[str, bytes], track: Track | None) -> ObstacleLayout:
    """The run's race type and fixed obstacles; what cannot be drawn is said in `notes`."""
    found = _first_params(params_yaml)
    if found is None:
        return ObstacleLayout()
    name, params = found
    try:
        challenge = ChallengeConfig.from_training_params(params)
    except ValueError as error:
        return ObstacleLayout(notes=(f"{name}: {error}; obstacles not drawn.",))
    bots = (
        (
            f"{challenge.race_type}: {challenge.number_of_bot_cars} bot cars drove their lanes; the maps show where the car crashed, "
            "not the bots.",
        )
        if challenge.number_of_bot_cars
        else ()
    )
    if challenge.num_obstacles == 0:
        return ObstacleLayout(challenge.race_type, notes=bots)
    if challenge.randomize_obstacle_locations and not challenge.object_positions:
        return ObstacleLayout(
            challenge.race_type,
            notes=(
                f"{name}: the {challenge.num_obstacles} obstacles moved every episode (RANDOMIZE_OBSTACLE_LOCATIONS); "
                "the maps do not draw them.",
                *bots,
            ),
        )
    if track is None:
        return ObstacleLayout(challenge.race_type, notes=bots)
    reverse = str(params.get("REVERSE_DIR", "false")).strip().lower() in ("true", "1")
    notes = [
        f"{challenge.race_type}: {challenge.num_obstacles} fixed obstacles from {name} drawn on the track maps.",
        *bots,
    ]
    if str(params.get("ALTERNATE_DRIVING_DIRECTION", "false")).strip().lower() in ("true", "1"):
        notes.append(
            "The driving direction alternated; the maps draw the obstacles of the route's own direction (the "
            "reversed episodes had them at the same share of the lap counted the other way)."
        )
    placed = place_obstacles(track.reversed() if reverse else track, challenge, np.random.default_rng(0))
    return ObstacleLayout(challenge.race_type, tuple(placed), tuple(notes))
