"""Track names as DeepRacer on AWS shows them ("Forever Raceway", clockwise) and the route name the SimApp loads.

DeepRacer on AWS (DRoA) lists its tracks in `source/libs/config/src/data/tracks.json`: a display name, the
`trackId` (the SimApp's WORLD_NAME), the enabled directions and the default one. For a track with two directions it
sends `WORLD_NAME=<trackId>` and `TRACK_DIRECTION_CLOCKWISE`, and the SimApp loads `<trackId>_cw` or `<trackId>_ccw`;
for a single-direction track it sends the bare trackId and no direction.

racer does not ship that list: `racer track import --droa tracks.json` stores a compact copy (`droa_tracks.json`) in
the route library, and a `droa_tracks.json` in any folder of the route search path is read (the first folder naming a
trackId wins). Without it, names are route names and directions are checked against the route files themselves.
"""

from __future__ import annotations

import json
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

from racer.shared.sim.route_search import (
    CLOCKWISE_SUFFIX,
    COUNTER_CLOCKWISE_SUFFIX,
    ROUTE_SUFFIX,
    RouteNotFoundError,
    find_route,
    is_route_name,
    search_folders,
)

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
        tracks.append(
            DroaTrack(
                name=str(row["name"]),
                track_id=str(row["trackId"]),
                directions=directions,
                default_direction=default if default in directions else directions[0],
                length_m=float(length) if isinstance(length, (int, float)) else None,
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


_CACHE: dict[tuple[str, float], tuple[DroaTrack, ...]] = {}


def load_catalogue(folders: Sequence[Path] | None = None) -> tuple[DroaTrack, ...]:
    """Every `droa_tracks.json` on the search path, merged in order (the first folder naming a trackId wins)."""
    merged: dict[str, DroaTrack] = {}
    for folder in search_folders() if folders is None else folders:
        path = Path(folder) / CATALOGUE_FILE
        if not path.is_file():
            continue
        key = (str(path), path.stat().st_mtime)
        if key not in _CACHE:
            _CACHE[key] = read_catalogue(path)
        for track in _CACHE[key]:
            merged.setdefault(track.track_id, track)
    return tuple(merged.values())


def _folded(text: str) -> str:
    return re.sub(r"[^0-9a-z]+", "", text.lower())


def find_droa_track(name: str, catalogue: Iterable[DroaTrack]) -> DroaTrack | None:
    """By trackId (exact), then display name or trackId ignoring case, spaces and punctuation."""
    tracks = list(catalogue)
    for track in tracks:
        if track.track_id == name:
            return track
    folded = _folded(name)
    for track in tracks:
        if folded in (_folded(track.name), _folded(track.track_id)):
            return track
    return None


@dataclass(frozen=True)
class ResolvedTrack:
    """What `--track NAME --direction D` means: the route name to load and where it came from."""

    world_name: str
    """A route name on the search path (or the path given)."""
    droa: DroaTrack | None = None
    direction: str | None = None


def _route_direction(name: str, folders: Sequence[Path] | None) -> str | None:
    """CLOCKWISE or COUNTER_CLOCKWISE for a route that exists, None when there is no such route."""
    from racer.shared.sim.track import Track  # shapely and numpy, only when a direction is asked

    try:
        path = find_route(name, folders) if is_route_name(name) else Path(name)
    except RouteNotFoundError:
        return None
    if not path.is_file():
        return None
    return COUNTER_CLOCKWISE if Track.load(path).is_ccw else CLOCKWISE


def _exists(name: str, folders: Sequence[Path] | None) -> bool:
    try:
        find_route(name, folders)
    except RouteNotFoundError:
        return False
    return True


def resolve_track(
    name: str | Path, direction: str | None = None, folders: Sequence[Path] | None = None
) -> ResolvedTrack:
    """The route for a track name (route name, DRoA trackId or display name, or a .npy path) and a direction
    (None: a route name as given, a DRoA display name in its default direction).

    A direction the track does not offer raises TrackDirectionError naming the ones it does; with no DRoA entry the
    directions are those of the route files (`<name>_cw`/`_ccw`, or the bare route's own orientation)."""
    text = str(name)
    wanted = parse_direction(direction) if direction else None
    if not is_route_name(text):
        if wanted is not None:
            runs = _route_direction(text, folders)
            if runs is not None and runs != wanted:
                raise TrackDirectionError(
                    f"route {text} runs {direction_label(runs)}, not {direction_label(wanted)}; it offers "
                    f"{direction_label(runs)} only"
                )
        return ResolvedTrack(text, None, wanted)
    for suffix, suffix_direction in ((CLOCKWISE_SUFFIX, CLOCKWISE), (COUNTER_CLOCKWISE_SUFFIX, COUNTER_CLOCKWISE)):
        if text.endswith(suffix) and _exists(text, folders):
            if wanted is not None and wanted != suffix_direction:
                raise TrackDirectionError(
                    f"route {text} is the {direction_label(suffix_direction)} direction; for "
                    f"{direction_label(wanted)} give {text.removesuffix(suffix)} with --direction"
                )
            return ResolvedTrack(text, None, suffix_direction)
    catalogue = load_catalogue(folders)
    entry = find_droa_track(text, catalogue)
    if entry is not None:
        if wanted is None and text == entry.track_id:
            return ResolvedTrack(text, entry, None)  # a route name as DeepRacer users write it, as given
        chosen = wanted or entry.default_direction
        world = entry.world_name(chosen)
        if (
            world != entry.track_id
            and not _exists(world, folders)
            and _route_direction(entry.track_id, folders) == chosen
        ):
            world = entry.track_id  # only the bare route is installed, and it runs this way
        return ResolvedTrack(world, entry, chosen)
    if wanted is None:
        return ResolvedTrack(text, None, None)
    suffixed = text + (CLOCKWISE_SUFFIX if wanted == CLOCKWISE else COUNTER_CLOCKWISE_SUFFIX)
    if _exists(suffixed, folders):
        return ResolvedTrack(suffixed, None, wanted)
    runs = _route_direction(text, folders)
    if runs is None:
        return ResolvedTrack(suffixed, None, wanted)  # as the SimApp; loading it lists where it looked
    if runs != wanted:
        raise TrackDirectionError(
            f"track {text} is not driven {direction_label(wanted)}: there is no {suffixed}{ROUTE_SUFFIX} and "
            f"{text}{ROUTE_SUFFIX} runs {direction_label(runs)}; it offers {direction_label(runs)} only"
        )
    return ResolvedTrack(text, None, wanted)


def world_name_for_direction(world_name: str, clockwise: bool | None, folders: Sequence[Path] | None = None) -> str:
    """The route name for WORLD_NAME driven in a direction (TRACK_DIRECTION_CLOCKWISE; None: the name as given).

    The SimApp appends `_cw` (true) or `_ccw` (false). DeepRacer-on-AWS sets the key only for tracks with two enabled
    directions; a single-direction track is the bare trackId. So: a track the DeepRacer-on-AWS track list (on the
    search path) gives one direction stays bare -- a direction it does not offer is refused, naming the one it does;
    a name with no suffixed route file but a bare one stays bare when the bare route runs that way. Otherwise the
    suffix is appended as the SimApp does (a missing file is then reported where the route is loaded)."""
    if clockwise is None:
        return world_name
    return resolve_track(world_name, "clockwise" if clockwise else "counter-clockwise", folders).world_name
