"""Finding a route file by its DeepRacer name (`WORLD_NAME`): a search path of folders, racer's `tracks/` last.

DeepRacer users name tracks (`WORLD_NAME: reInvent2019_track` in training_params.yaml, DRfC's `DR_WORLD_NAME`); the
SimApp loads `routes/<WORLD_NAME>.npy`. The folders of `RACER_ROUTES_PATH` (read in `racer.shared.config`) come
first, in order, then the per-user route library (`racer track import` copies route files there), then racer's own
`tracks/`. A SimApp route name none of them has is fetched on first use and kept in the user's cache
(`racer.shared.sim.tracks.route_fetch`, from the catalogue racer ships). DeepRacer-on-AWS sends
`TRACK_DIRECTION_CLOCKWISE` only for its tracks with two directions; the SimApp's yaml reader then appends `_cw` or
`_ccw` to the name. Its single-direction tracks are the bare trackId (`track_catalog.world_name_for_direction`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

from racer.shared.config import ROUTES_PATH_VARIABLE, route_folders, route_library
from racer.shared.sim.tracks.route_fetch import RouteFetchError, fetch_catalogue_route

ROUTE_SUFFIX = ".npy"


class RouteNotFoundError(ValueError):
    """No route file of that name in any folder of the search path; the message lists where it looked."""


def default_tracks_dir() -> Path:
    """The repository's `tracks/` folder (the `racer.tracks` package directory)."""
    import racer.tracks

    return Path(racer.tracks.__file__).resolve().parent


def search_folders(environ: Mapping[str, str] | None = None) -> tuple[Path, ...]:
    """RACER_ROUTES_PATH's folders in order, then the route library (when the environment names a home), then
    racer's own `tracks/`."""
    library = route_library(environ)
    return (*route_folders(environ), *((library,) if library is not None else ()), default_tracks_dir())


def is_route_name(name_or_path: str | Path) -> bool:
    """A bare name (`reInvent2019_track`) rather than a path (`routes/x.npy`, `x.npy`)."""
    text = str(name_or_path)
    return not text.endswith(ROUTE_SUFFIX) and Path(text).parent == Path(".")


def available_routes(folders: Sequence[Path]) -> list[str]:
    """Route names found in the folders (the first folder holding a name wins), sorted."""
    names: set[str] = set()
    for folder in folders:
        names.update(path.stem for path in Path(folder).glob(f"*{ROUTE_SUFFIX}"))
    return sorted(names)


def find_route(name: str, folders: Sequence[Path] | None = None) -> Path:
    """`<folder>/<name>.npy` of the first folder that has it. With the default search path, a SimApp route name found
    in none of them is fetched (or taken from the cache, `racer.shared.sim.tracks.route_fetch`); an unknown name lists the
    folders searched."""
    searched = tuple(folders) if folders is not None else search_folders()
    for folder in searched:
        candidate = Path(folder) / f"{name}{ROUTE_SUFFIX}"
        if candidate.is_file():
            return candidate
    if folders is None:
        try:
            fetched = fetch_catalogue_route(name)
        except RouteFetchError as error:
            raise RouteNotFoundError(str(error)) from None
        if fetched is not None:
            return fetched
    where = ", ".join(str(folder) for folder in searched)
    ours = ", ".join(available_routes([default_tracks_dir()]))
    raise RouteNotFoundError(
        f"no track named {name!r} ({name}{ROUTE_SUFFIX}); looked in: {where}. Set {ROUTES_PATH_VARIABLE} to folders "
        f"of DeepRacer route files (for example the SimApp's bundle/routes), copy them to the route library with "
        f"`racer track import FOLDER`, or give a path to a .npy file (`racer track list` names every SimApp track); "
        f"racer's own tracks: {ours}"
    )
