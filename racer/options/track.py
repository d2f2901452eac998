"""`--track` and its `--direction`: the pair resolves to one route name before the command runs.

`--track "Forever Raceway" --direction clockwise` becomes `2024_reinvent_champ_cw`; a direction the track does not
offer is a usage error naming the ones it does (`racer.shared.sim.tracks.catalog.resolve_track`).
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any

import click

from racer.shared.sim.config import DEFAULT_TRACK
from racer.shared.sim.tracks.catalog import resolve_track
from racer.shared.sim.tracks.droa_tracks import TrackDirectionError

TRACK_HELP = (
    "A track: any SimApp track by name (fetched on first use; reinvent_base is re:Invent 2018), a DeepRacer-on-AWS "
    'name ("Forever Raceway"), a route on the search path (racer\'s own, RACER_ROUTES_PATH, the route library) or a '
    ".npy path. `racer track list` names them."
)

DIRECTION_HELP = (
    "clockwise or counter-clockwise: picks the route of --track for that direction (<trackId>_cw/_ccw, or the bare "
    "trackId of a single-direction DeepRacer-on-AWS track); default: the name as given, a DeepRacer-on-AWS display "
    "name in its default direction."
)


def track_option(required: bool = False):
    """`--track NAME`: racer's default track unless the command requires one."""
    if required:
        return click.option("--track", required=True, help=TRACK_HELP)
    return click.option("--track", default=DEFAULT_TRACK, show_default=True, help=TRACK_HELP)


def resolved_track_name(track: str, direction: str | None) -> str:
    """The route name for `--track` and `--direction`, or a click usage error."""
    try:
        return resolve_track(track, direction).world_name
    except TrackDirectionError as error:
        raise click.BadParameter(str(error), param_hint="'--direction'") from error
    except ValueError as error:
        raise click.BadParameter(str(error), param_hint="'--track' / '--direction'") from error


def direction_option(command: Callable[..., Any]) -> Callable[..., Any]:
    """Add `--direction` to a click command that has a `track` parameter, and hand it the resolved route name."""

    @click.option("--direction", default=None, help=DIRECTION_HELP)
    @functools.wraps(command)
    def wrapper(*args: Any, direction: str | None = None, **kwargs: Any) -> Any:
        kwargs["track"] = resolved_track_name(kwargs["track"], direction)
        return command(*args, **kwargs)

    return wrapper
