"""`racer track line NAME --out DIR`: the car's fastest line round a track and its speed profile, for users.

Writes line.csv, line.npy, line.json (`racer.racing_line.export`) and line.png (`racer.racing_line.picture`); keeps the
line in racer's cache (`racer.racing_line.cache`), so asking again for the same track, direction, car and world reads
it back instead of optimising again.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import TYPE_CHECKING

import click

from racer.options.generation import car_profile_option, generation_option, world_option
from racer.options.track import direction_option
from racer.shared.config import CACHE_HOME_VARIABLE, line_cache
from racer.shared.sim.car.dynamics import car_profile as car_profile_named
from racer.shared.sim.generations.catalog import generation as generation_named

if TYPE_CHECKING:
    from racer.racing_line import OptimiserProgress, RacingLine
    from racer.racing_line.cache import CachedLine

PROGRESS_EVERY_S = 2.0
"""How often a stage's iterations are reported on stderr (each stage's end always is)."""


class _ProgressLines:
    """Prints the optimiser's stage and latest lap time to stderr, at most every PROGRESS_EVERY_S within a stage."""

    def __init__(self, track: str) -> None:
        self.track = track
        self.started = time.monotonic()
        self.last_printed = self.started

    def __call__(self, progress: OptimiserProgress) -> None:
        now = time.monotonic()
        if not progress.stage_done and now - self.last_printed < PROGRESS_EVERY_S:
            return
        self.last_printed = now
        stage = f"stage {progress.stage}/{progress.stages} (a control every {progress.control_spacing_m:g} m)"
        what = (
            f"done after {progress.iteration} iterations" if progress.stage_done else f"iteration {progress.iteration}"
        )
        click.echo(
            f"line: {self.track}: {stage} {what}, lap {progress.lap_time_s:.3f} s [{now - self.started:.0f} s]",
            err=True,
        )


@click.command("line")
@click.argument("track", metavar="NAME")
@direction_option
@generation_option
@car_profile_option
@world_option()
@click.option(
    "--out",
    "out_dir",
    type=click.Path(file_okay=False, path_type=Path),
    required=True,
    help="Folder to write line.csv, line.npy, line.json and line.png into (made if missing).",
)
@click.option("--recompute", is_flag=True, help="Optimise again even when the cache holds this line.")
def line_command(track: str, generation: str, car_profile: str, world: str, out_dir: Path, recompute: bool) -> None:
    """The car's fastest line round NAME and its speed profile: line.csv and line.npy (x, y, speed_mps, time_s,
    curvature_per_m, distance_m in DeepRacer's route coordinates, the first station repeated last), line.json (the
    flying lap, 3 laps from rest, length, speeds, braking points, what it is of) and line.png (the line coloured by
    speed, braking points marked). Names resolve as in `racer track show`. The line is kept in racer's cache, keyed by
    the route file, direction, car and world."""
    # The line's modules load MuJoCo's car model and scipy: imported when a line is asked for, so `racer track` starts
    # fast.
    from racer.racing_line import CarLimits, LapTimeBoundError, racing_line
    from racer.racing_line.cache import LineCache, cached_racing_line, direction_of, line_key
    from racer.racing_line.export import PNG_FILE, LineAbout, write_line_files
    from racer.racing_line.picture import draw_line
    from racer.shared.sim.tracks.track import Track, TrackError

    try:
        route = Track.load(track)
        dynamics = car_profile_named(car_profile) if car_profile else generation_named(generation).car
        limits = CarLimits.of_car(dynamics, world=world)
    except (TrackError, ValueError) as error:
        raise click.ClickException(str(error)) from error
    try:
        key = line_key(route, dynamics, limits)
        folder = line_cache()
        started = time.monotonic()
        progress = _ProgressLines(route.name)
        if folder is None:
            click.echo(f"line: no home folder for racer's cache (set {CACHE_HOME_VARIABLE}): not kept", err=True)
            found = None
            line = racing_line(route, limits, key.spacing_m, key.control_spacings_m, progress)
        else:
            cache = LineCache(folder)
            if recompute:
                cache.path(route.name, key).unlink(missing_ok=True)
            found = cached_racing_line(route, key, cache, progress)
            line = found.line
    except LapTimeBoundError as error:
        raise click.ClickException(f"racer track line: {error}") from error
    _say_where_from(found, time.monotonic() - started)
    about = LineAbout(
        track=route.name,
        direction=direction_of(route),
        generation=generation,
        car_profile=limits.car_profile,
        world=world,
        route_sha256=key.route_sha256,
    )
    paths = write_line_files(line, about, out_dir)
    title = f"{route.name} ({about.direction}), {generation} car ({about.car_profile}), {world} world"
    paths[PNG_FILE] = draw_line(route, line, title, out_dir / PNG_FILE)
    _say_line(line)
    for path in paths.values():
        click.echo(str(path))


def _say_where_from(found: CachedLine | None, elapsed_s: float) -> None:
    if found is not None and found.problem is not None:
        click.echo(f"line: {found.problem}: computed again", err=True)
    if found is None:
        click.echo(f"computed in {elapsed_s:.0f} s (not cached)")
    elif found.from_cache:
        click.echo(f"from the cache: {found.path}")
    else:
        click.echo(f"computed in {elapsed_s:.0f} s, cached: {found.path}")


def _say_line(line: RacingLine) -> None:
    click.echo(
        f"{line.track}: flying lap {line.lap_time_s:.3f} s; 3 laps from rest "
        f"{', '.join(f'{t:.3f}' for t in line.standing_laps_s)} s (mean {line.standing_average_s:.3f} s); "
        f"line {line.length_m:.2f} m; speeds {line.speeds_mps.min():.2f}-{line.speeds_mps.max():.2f} m/s; "
        f"{len(line.braking_indices)} braking points"
    )
