"""The tyre fit's command: fit the car's constants to real simtraces and replay them in MuJoCo, or screen the
replay's hypotheses with the fit's twin."""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path

import click

from benchmarks.fidelity.simtrace_replay import (
    SPEED_BANDS_MPS,
    CarReplay,
    Segment,
    band_label,
    error_table,
    load_replayable,
    replay_errors,
    replay_files,
)
from research import route_option, simtraces_option
from research.tyre_fit.hypotheses import screen
from research.tyre_fit.inertia_profile import inertia_profile
from research.tyre_fit.twin import CarConstants, SegmentBatch, fit, leave_one_file_out

FIT_MODES = ("all", "leave-one-file-out")


def fitted_constants(segments: Sequence[Segment], mode: str, progress: bool = False) -> dict[str, CarConstants]:
    """Per simtrace file, the constants its segments replay with: fitted on all files (`all`, in sample) or on the
    other files (`leave-one-file-out`, held out)."""
    batch = SegmentBatch.of(segments)
    if mode == "all":
        fitted = fit(batch, progress=progress)
        return {segment.source: fitted for segment in segments}
    if mode == "leave-one-file-out":
        return leave_one_file_out(batch, progress=progress)
    raise ValueError(f"unknown fit mode {mode!r}: {' or '.join(FIT_MODES)}")


def run_fit(simtraces: Sequence[Path], route: Path, mode: str, progress: bool = False) -> dict:
    """The replay's error table with the fitted constants, each file replayed in MuJoCo with its own."""
    segments = load_replayable(simtraces)
    try:
        constants = fitted_constants(segments, mode, progress)
    except ValueError as exc:
        raise click.ClickException(str(exc)) from None
    replay = CarReplay(route)
    errors = []
    try:
        for source, fold in sorted(constants.items()):
            replay.car.retune(replay.model, fold.tyres, fold.steering_time_constant_s, fold.yaw_inertia_kgm2)
            errors += replay_errors(replay, [segment for segment in segments if segment.source == source], progress)
    finally:
        replay.close()
    return {
        **error_table(segments, len(simtraces), errors),
        "fit": mode,
        "constants": {source: c.as_dict() for source, c in sorted(constants.items())},
    }


def run_hypotheses(simtraces: Sequence[Path]) -> dict:
    """The replay's reading of the logs varied one assumption at a time (hypotheses.py), with the shipped constants."""
    segments = load_replayable(simtraces)
    return {
        "segments": len(segments),
        "files": len(simtraces),
        "hypotheses": screen(segments, SPEED_BANDS_MPS, band_label),
    }


def run_inertia_profile(simtraces: Sequence[Path], values_kgm2: Sequence[float], held_out: bool) -> dict:
    """How firmly the logs set the yaw inertia (inertia_profile.py)."""
    segments = load_replayable(simtraces)
    try:
        rows = inertia_profile(SegmentBatch.of(segments), values_kgm2, held_out=held_out)
    except ValueError as exc:
        raise click.ClickException(str(exc)) from None
    return {"segments": len(segments), "files": len(simtraces), "yaw_inertia_profile": rows}


@click.command(name="tyre-fit")
@simtraces_option
@route_option
@click.option(
    "--fit",
    "mode",
    type=click.Choice(FIT_MODES),
    default="all",
    show_default=True,
    help="Fit on all files and print the constants, or per file on the other files (held out; minutes per file).",
)
@click.option(
    "--hypotheses",
    is_flag=True,
    help="Instead: vary how the logs are read (command delay, time base, start state) with the twin (seconds).",
)
@click.option(
    "--yaw-inertia-profile",
    "profile_values_kgm2",
    type=click.FloatRange(min=0.0, min_open=True),
    multiple=True,
    help="Instead: hold the yaw inertia at this value (kg·m², repeatable), refit the rest with the twin, and report "
    "the loss in sample and held out per value (minutes per value; --fit all: in sample only).",
)
def tyre_fit_command(
    simtraces: Path, route: Path, mode: str, hypotheses: bool, profile_values_kgm2: tuple[float, ...]
) -> None:
    """Fit the car's dynamics constants to real simtraces and replay them; one JSON line."""
    paths = replay_files(simtraces, route)
    if profile_values_kgm2:
        result = run_inertia_profile(paths, profile_values_kgm2, held_out=mode == "leave-one-file-out")
    elif hypotheses:
        result = run_hypotheses(paths)
    else:
        result = run_fit(paths, route, mode, progress=True)
    click.echo(json.dumps(result))
