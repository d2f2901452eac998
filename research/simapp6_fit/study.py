"""The simapp6 car fitted to DeepRacer on AWS's 2026 logs, reported on the file each fold did not see.

Three files of one run on Spain_track (two training iterations, one evaluation). Each fold fits the tyre fit's
planar twin (research/tyre_fit/twin.py) on two files and replays the third in MuJoCo with the fold's constants, as
`python -m benchmarks fidelity` replays (logged start, logged commands, 1/15 s per row). What the SimApp v6.0.5 files state is
kept, not fitted: Coulomb μ 0.5 wheels (peak grip 1 × μ × load) rolling on the 0.036 m wheel mesh
(`car/simapp_profiles.py`). What they leave to the simulator (the cornering and drive stiffness, the drive's cap, how
fast the hinges follow, the yaw inertia racer's body needs) is fitted.
"""

from __future__ import annotations

import json
import sys
from collections.abc import Sequence
from pathlib import Path

import click
import numpy as np

from benchmarks.fidelity.simtrace_replay import (
    SPEED_BANDS_MPS,
    CarReplay,
    Segment,
    SegmentError,
    band_label,
    load_segments,
    replay_errors,
    replay_files,
)
from racer.shared.sim.car.dynamics import CAR_DYNAMICS, CarDynamics
from racer.shared.sim.car.simapp_profiles import (
    ROS1_YAW_INERTIA_KGM2,
    ROS2_STEERING_TIME_CONSTANT_S,
    WHEEL_MESH_RADIUS_M,
)
from racer.shared.sim.car.tyres import TyreParams
from research import DEEPRACER_DATA, simtraces_option
from research.replay_limits.noise import in_progress_rows, replay_floor_m, row_timing
from research.tyre_fit.twin import CarConstants, SegmentBatch, fit

SPAIN_ROUTE = DEEPRACER_DATA / "simapp-routes" / "Spain_track.npy"
FIXED_FACTS = ("min_slip_speed_mps", "front_peak_grip", "rear_peak_grip", "rolling_radius_m")
"""Kept at `START`'s values: the SimApp's μ 0.5 Coulomb wheels and 0.036 m mesh, and the twin's numerical guard."""
START = CarConstants(
    TyreParams(50.0, 50.0, 1.0, 1.0, 40.0, 22.0, WHEEL_MESH_RADIUS_M, 0.3), 0.05, ROS1_YAW_INERTIA_KGM2
)
"""Where every fold starts: round guesses for the fitted constants, the source's facts for the others."""
REPORT_HORIZON_S = 1.0
"""Segments of 1 s: the training files' episodes (about 1.2 s of driving) hold almost none of the bench's 2 s."""
FIT_STRIDE_ROWS = 4
"""The fit takes a segment every 4 rows (the report every 8, as the bench): more start phases from short episodes."""
LOSS_HORIZONS_S = (0.5, 1.0)
"""The fit minimises the mean position error at these times after the start (the segments are 1 s long)."""
EVALUATIONS = 1500
MIN_BAND_SEGMENTS = 30
"""A band is judged (<= 0.15 m) only where it holds at least this many segments."""
BASELINE_PROFILES = ("gazebo", "simapp6-ros2", "simtrace-fit")


def dynamics_of(constants: CarConstants) -> CarDynamics:
    return CarDynamics(constants.tyres, constants.steering_time_constant_s, constants.yaw_inertia_kgm2)


def band_table(segments: Sequence[Segment], errors: Sequence[SegmentError]) -> dict[str, dict]:
    """Per speed band: segments and the median position error after 1 s (m)."""
    table = {}
    for low, high in SPEED_BANDS_MPS:
        members = [e.position_m[REPORT_HORIZON_S] for e in errors if low <= e.start_speed_mps < high]
        table[band_label(low, high)] = {
            "segments": len(members),
            "position_m_1s_median": round(float(np.median(members)), 4) if members else None,
        }
    return table


def fold_constants(
    segments: Sequence[Segment], progress: bool, start: CarConstants = START, fixed: tuple[str, ...] = FIXED_FACTS
) -> dict[str, CarConstants]:
    """Per file, the constants fitted on the other files' segments; under "all files", on every segment."""
    batch = SegmentBatch.of(segments)
    folds = {}
    for source in [*np.unique(batch.sources).tolist(), "all files"]:
        training = batch if source == "all files" else batch.subset(batch.sources != source)
        if progress:
            print(f"fit: fitting {'on all files' if source == 'all files' else 'without ' + source}",
                  file=sys.stderr, flush=True)  # fmt: skip
        folds[source] = fit(training, start, EVALUATIONS, fixed=fixed, horizons_s=LOSS_HORIZONS_S)
    return folds


def source_servo_held_out(route: Path, fit_segments: Sequence[Segment], report_segments: Sequence[Segment]) -> dict:
    """The same leave-one-file-out fit with the hinge servo held at the 0.158 s read from the v6.0.5 controllers
    (gz_ros2_control's 60 Hz position loop, `car.simapp_profiles.ROS2_STEERING_TIME_CONSTANT_S`)."""
    start = CarConstants(START.tyres, ROS2_STEERING_TIME_CONSTANT_S, START.yaw_inertia_kgm2)
    folds = fold_constants(fit_segments, False, start, (*FIXED_FACTS, "steering_time_constant_s"))
    segments, errors = [], []
    for source, constants in folds.items():
        if source != "all files":
            own = [segment for segment in report_segments if segment.source == source]
            segments += own
            errors += replay_errors_for(route, dynamics_of(constants), own)
    return band_table(segments, errors)


def run_fit(simtraces: Sequence[Path], route: Path, progress: bool = False) -> dict:
    fit_segments = load_segments(simtraces, REPORT_HORIZON_S, FIT_STRIDE_ROWS)
    report_segments = load_segments(simtraces, REPORT_HORIZON_S)
    folds = fold_constants(fit_segments, progress)
    files = sorted(source for source in folds if source != "all files")
    bench_segments = load_segments(simtraces)  # the bench's 2 s segments: the evaluation file's, mostly
    held_out: list[SegmentError] = []
    held_out_segments: list[Segment] = []
    held_out_bench: list[SegmentError] = []
    per_fold = {}
    for source in files:
        own = [segment for segment in report_segments if segment.source == source]
        errors = replay_errors_for(route, dynamics_of(folds[source]), own)
        per_fold[source] = {"constants": folds[source].as_dict(), "held_out": band_table(own, errors)}
        held_out += errors
        held_out_segments += own
        own_bench = [segment for segment in bench_segments if segment.source == source]
        held_out_bench += replay_errors_for(route, dynamics_of(folds[source]), own_bench)
    pooled = band_table(held_out_segments, held_out)
    judged = {band: entry for band, entry in pooled.items() if entry["segments"] >= MIN_BAND_SEGMENTS}
    shipped = folds["all files"]
    baselines = {
        name: {
            "report_segments": band_table(
                report_segments, replay_errors_for(route, CAR_DYNAMICS[name], report_segments)
            ),
            "bench_segments": band_table(bench_segments, replay_errors_for(route, CAR_DYNAMICS[name], bench_segments)),
        }
        for name in BASELINE_PROFILES
    }
    return {
        "study": "simapp6-fit",
        "files": [Path(path).name for path in simtraces],
        "segments": {"fit": len(fit_segments), "report": len(report_segments), "bench": len(bench_segments)},
        "folds": per_fold,
        "held_out": pooled,
        "held_out_on_the_bench_segments": band_table(bench_segments, held_out_bench),
        "goal_le_0_15_m_in_bands_with_30_segments": all(
            entry["position_m_1s_median"] <= 0.15 for entry in judged.values()
        ),
        "all_files": {
            "constants": shipped.as_dict(),
            "in_sample": band_table(report_segments, replay_errors_for(route, dynamics_of(shipped), report_segments)),
        },
        "baselines_same_segments": baselines,
        "held_out_with_the_source_servo": source_servo_held_out(route, fit_segments, report_segments),
        "limits": log_limits(simtraces, shipped),
    }


def replay_errors_for(route: Path, dynamics: CarDynamics, segments: Sequence[Segment]) -> list[SegmentError]:
    replay = CarReplay(route, dynamics)
    try:
        return replay_errors(replay, segments)
    finally:
        replay.close()


def log_limits(simtraces: Sequence[Path], constants: CarConstants) -> dict:
    """What the logs themselves allow: the per-row distance jitter the timestamps do not explain, and an exact twin
    (the constants fitted on all files) replayed on its own pseudo-log carrying that jitter, per band after 1 s
    (research/replay_limits/noise.py), on the bench's 2 s segments (the floor needs a pose past the horizon)."""
    timing = row_timing(in_progress_rows(simtraces))
    segments = load_segments(simtraces)
    floor = replay_floor_m(segments, constants, timing.unexplained_jitter_s)
    bands = {}
    for low, high in SPEED_BANDS_MPS:
        members = [f for s, f in zip(segments, floor, strict=True) if low <= s.start_speed_mps < high]
        bands[band_label(low, high)] = {
            "segments": len(members),
            "floor_m_1s_median": round(float(np.median(members)), 4) if members else None,
        }
    return {
        "rows_at_a_held_speed": timing.rows,
        "step_s": round(timing.step_s, 4),
        "tstamp_share": round(timing.tstamp_share, 3),
        "unexplained_jitter_s": round(timing.unexplained_jitter_s, 4),
        "replay_floor": bands,
    }


@click.command(name="simapp6-fit")
@simtraces_option
@click.option(
    "--route",
    type=click.Path(exists=True, dir_okay=False, path_type=Path),
    default=SPAIN_ROUTE,
    show_default=True,
    help="The route the 2026 logs were driven on; files logged on another track are left out.",
)
def simapp6_fit_command(simtraces: Path, route: Path) -> None:
    """Fit the simapp6 car on DeepRacer on AWS's logs leaving one file out; held-out errors per band, one JSON line."""
    paths = replay_files(simtraces, route)
    if len(paths) < 2:
        raise click.ClickException(f"leaving one file out needs two or more files driven on {route.name}")
    click.echo(json.dumps(run_fit(paths, route, progress=True)))
