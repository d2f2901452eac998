"""From a track name and a direction to the route name the SimApp loads: route names, DeepRacer on AWS's trackIds and
display names ("Forever Raceway", clockwise), `_cw` / `_ccw` routes.

DeepRacer on AWS's track list (`racer.shared.sim.tracks.droa_tracks`) comes from racer's route catalogue; a `droa_tracks.json`
in a folder of the route search path (`racer track import --droa tracks.json` writes one into the route library) comes
first (the first folder naming a trackId wins). With folders given explicitly, only their lists and route files count.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

from racer.shared.sim.tracks.droa_tracks import (
    CATALOGUE_FILE,
    CLOCKWISE,
    CLOCKWISE_SUFFIX,
    COUNTER_CLOCKWISE,
    COUNTER_CLOCKWISE_SUFFIX,
    DroaTrack,
    TrackDirectionError,
    direction_label,
    parse_direction,
    read_catalogue,
)
from racer.shared.sim.tracks.route_search import (
    ROUTE_SUFFIX,
    RouteNotFoundError,
    find_route,
    is_route_name,
    search_folders,
)
from racer.shared.sim.tracks.simapp_routes import shipped_catalogue

_CACHE: dict[tuple[str, float], tuple[DroaTrack, ...]] = {}


def load_catalogue(folders: Sequence[Path] | None = None) -> tuple[DroaTrack, ...]:
    """Every `droa_tracks.json` on the search path, merged in order (the first folder naming a trackId wins); with the
    default search path, the list in racer's route catalogue comes last."""
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
    if folders is None:
        for track in shipped_catalogue().droa_tracks:
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
    from racer.shared.sim.tracks.track import Track  # shapely and numpy, only when a direction is asked

    if is_route_name(name) and folders is None and not _on_search_path(name):
        route = shipped_catalogue().route(name)  # its facts, with no fetch
        if route is None:
            return None
        return COUNTER_CLOCKWISE if route.direction == "counter-clockwise" else CLOCKWISE
    try:
        path = find_route(name, folders) if is_route_name(name) else Path(name)
    except RouteNotFoundError:
        return None
    if not path.is_file():
        return None
    return COUNTER_CLOCKWISE if Track.load(path).is_ccw else CLOCKWISE


def _on_search_path(name: str) -> bool:
    return any((Path(folder) / f"{name}{ROUTE_SUFFIX}").is_file() for folder in search_folders())


def _exists(name: str, folders: Sequence[Path] | None) -> bool:
    """On the search path, or (with the default one) in racer's route catalogue: fetched only when loaded."""
    if folders is None:
        return _on_search_path(name) or shipped_catalogue().route(name) is not None
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
