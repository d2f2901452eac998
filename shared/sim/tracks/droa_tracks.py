"""DeepRacer on AWS's track list: display names, trackIds (the SimApp's WORLD_NAME) and directions.

DeepRacer on AWS (DRoA) lists its tracks in `source/libs/config/src/data/tracks.json` (aws-solutions/deepracer-on-aws):
a display name, the `trackId`, the enabled directions and the default one, a description and a difficulty. For a track
with two directions it sends `WORLD_NAME=<trackId>` and `TRACK_DIRECTION_CLOCKWISE`, and the SimApp loads
`<trackId>_cw` or `<trackId>_ccw`; for a single-direction track it sends the bare trackId and no direction.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

CLOCKWISE_SUFFIX = "_cw"
COUNTER_CLOCKWISE_SUFFIX = "_ccw"
CLOCKWISE = "CLOCKWISE"
COUNTER_CLOCKWISE = "COUNTER_CLOCKWISE"
DIRECTIONS = (CLOCKWISE, COUNTER_CLOCKWISE)
CATALOGUE_FILE = "droa_tracks.json"
"""The compact DRoA track list, looked for in every folder of the route search path."""

_DIRECTION_WORDS = {
    "clockwise": CLOCKWISE,
    "cw": CLOCKWISE,
    "counterclockwise": COUNTER_CLOCKWISE,
    "counter_clockwise": COUNTER_CLOCKWISE,
    "counter-clockwise": COUNTER_CLOCKWISE,
    "anticlockwise": COUNTER_CLOCKWISE,
    "anti-clockwise": COUNTER_CLOCKWISE,
    "ccw": COUNTER_CLOCKWISE,
}


class TrackDirectionError(ValueError):
    """The track is not driven in the direction asked for; the message names the direction(s) it offers."""


def parse_direction(text: str) -> str:
    """`clockwise`/`cw`/`CLOCKWISE` -> CLOCKWISE; `counter-clockwise`/`counterclockwise`/`ccw` -> COUNTER_CLOCKWISE."""
    key = text.strip().lower()
    if key not in _DIRECTION_WORDS:
        raise ValueError(f"direction {text!r}: expected clockwise (cw) or counter-clockwise (ccw)")
    return _DIRECTION_WORDS[key]


def direction_label(direction: str) -> str:
    return "clockwise" if direction == CLOCKWISE else "counter-clockwise"


@dataclass(frozen=True)
class DroaTrack:
    """One DeepRacer-on-AWS track: display name, trackId (WORLD_NAME), enabled directions, default direction."""

    name: str
    track_id: str
    directions: tuple[str, ...]
    default_direction: str
    length_m: float | None = None
    description: str | None = None
    difficulty: int | None = None
    """DeepRacer on AWS's difficulty score (higher is harder)."""

    def world_name(self, direction: str) -> str:
        """The route the SimApp loads for this direction: the bare trackId when the track has one direction."""
        if direction not in self.directions:
            offered = " and ".join(direction_label(d) for d in self.directions)
            raise TrackDirectionError(
                f"{self.name} ({self.track_id}) is not driven {direction_label(direction)}; it offers {offered}"
            )
        if len(self.directions) == 1:
            return self.track_id
        return self.track_id + (CLOCKWISE_SUFFIX if direction == CLOCKWISE else COUNTER_CLOCKWISE_SUFFIX)

    def to_compact(self) -> dict[str, object]:
        return {
            "name": self.name,
            "trackId": self.track_id,
            "directions": list(self.directions),
            "defaultDirection": self.default_direction,
            "length": self.length_m,
            "description": self.description,
            "difficulty": self.difficulty,
        }


def parse_catalogue(data: object, source: str = CATALOGUE_FILE) -> tuple[DroaTrack, ...]:
    """DRoA's own tracks.json (`{"tracks": [{name, trackId, enabledDirections, defaultDirection, length, disabled}]}`)
    or racer's compact list (`[{name, trackId, directions, defaultDirection, length}]`); disabled tracks are left out."""
    rows = data.get("tracks") if isinstance(data, dict) else data
    if not isinstance(rows, list):
        raise ValueError(f"{source}: expected a list of tracks (or DeepRacer on AWS's {{'tracks': [...]}})")
    tracks = []
    for index, row in enumerate(rows):
        if not isinstance(row, dict) or not {"name", "trackId"} <= set(row):
            raise ValueError(f"{source}: track {index}: expected an object with name and trackId")
        if row.get("disabled"):
            continue
        raw_directions = row.get("directions", row.get("enabledDirections")) or [COUNTER_CLOCKWISE]
        try:
            directions = tuple(d for d in DIRECTIONS if d in {parse_direction(str(x)) for x in raw_directions})
            default = parse_direction(str(row.get("defaultDirection", directions[0])))
        except ValueError as error:
            raise ValueError(f"{source}: track {row['name']!r}: {error}") from None
        length = row.get("length")
        difficulty = row.get("difficulty")
        tracks.append(
            DroaTrack(
                name=str(row["name"]),
                track_id=str(row["trackId"]),
                directions=directions,
                default_direction=default if default in directions else directions[0],
                length_m=float(length) if isinstance(length, (int, float)) else None,
                description=str(row["description"]) if row.get("description") else None,
                difficulty=int(difficulty) if isinstance(difficulty, (int, float)) else None,
            )
        )
    return tuple(tracks)


def read_catalogue(path: str | Path) -> tuple[DroaTrack, ...]:
    path = Path(path)
    try:
        data = json.loads(path.read_text(encoding="utf-8-sig"))
    except json.JSONDecodeError as error:
        raise ValueError(f"{path}: line {error.lineno} column {error.colno}: {error.msg}") from None
    return parse_catalogue(data, str(path))
