"""The 2019 generation's car fitted on the one console log of that simulator in the test data, leaving one episode
out.

`checkpoints/reInvent2019-TestModel/sim-trace/evaluation_0-iteration.csv`: an evaluation on the DeepRacer console in
September 2020 (Gazebo classic, ROS 1; a model of version 3, as the 2019 sample checkpoints) on `Belille`, three
episodes of about 1,050 rows at 0.33-1 m/s. The 2022 console and DeepRacer-for-Cloud logs fit another car (the
`simtrace-fit` profile: a servo 4 × faster, 3 × the yaw inertia, stiffer tyres), so the console changed its car
between the two; this log is the nearest to 2019 there is. The file has 16 columns (no `pause_duration`), which
racer's simtrace reader does not take: the study reads a copy with that column added (0: no pause).

Everything else is research/simapp6_fit's method: the planar twin fitted on two episodes and replayed in MuJoCo on
the third, the SimApp's μ 0.5 wheels and 0.036 m mesh kept (they are the ROS 1 files' too: simapp_car_profiles.py),
and the drive's cap at their friction limit (`DRIVE_CAP_START`).
"""

from __future__ import annotations

import dataclasses
import json
import tempfile
from pathlib import Path

import click
import pandas as pd

from benchmarks.fidelity.simtrace_replay import Segment, SegmentError, load_segments
from racer.shared.sim.car.simapp_profiles import friction_drive_cap_n
from research import DEEPRACER_DATA
from research.simapp6_fit.study import (
    FIT_STRIDE_ROWS,
    FIXED_FACTS,
    REPORT_HORIZON_S,
    START,
    band_table,
    dynamics_of,
    fold_constants,
)
from research.simapp6_fit.study import replay_errors_for as replay

LOG = DEEPRACER_DATA / "checkpoints" / "reInvent2019-TestModel" / "sim-trace" / "evaluation_0-iteration.csv"
ROUTE = DEEPRACER_DATA / "simapp-routes" / "Belille.npy"
BASELINE_PROFILES = ("gazebo", "simtrace-fit", "simapp5-ros1", "simapp6-fit")
DRIVE_CAP_START = dataclasses.replace(
    START, tyres=dataclasses.replace(START.tyres, max_drive_force_n=friction_drive_cap_n())
)
"""The drive's cap is the ROS 1 files' friction limit, μ 0.5 × the weight (32.2 N): at 0.33-1 m/s the log never
reaches it (free, the folds put it anywhere from 19 N to 75 kN), so it is kept, not fitted."""


def episode_segments(log: Path, stride_rows: int) -> list[Segment]:
    """1 s segments of the log, each named by its episode (the folds) instead of its file."""
    rows = pd.read_csv(log)
    if "pause_duration" not in rows.columns:
        rows.insert(rows.columns.get_loc("episode_status") + 1, "pause_duration", 0.0)
    with tempfile.TemporaryDirectory(prefix="racer-console2020-") as folder:
        copy = Path(folder) / log.name
        rows.to_csv(copy, index=False)
        segments = load_segments([copy], REPORT_HORIZON_S, stride_rows)
    return [dataclasses.replace(segment, source=f"episode {segment.episode}") for segment in segments]


def run_fit(log: Path, route: Path, progress: bool = False) -> dict:
    fit_segments = episode_segments(log, FIT_STRIDE_ROWS)
    report_segments = episode_segments(log, 8)
    folds = fold_constants(fit_segments, progress, DRIVE_CAP_START, (*FIXED_FACTS, "max_drive_force_n"))
    held_out: list[SegmentError] = []
    ordered: list[Segment] = []
    per_fold = {}
    for source in sorted(name for name in folds if name != "all files"):
        own = [segment for segment in report_segments if segment.source == source]
        errors = replay(route, dynamics_of(folds[source]), own)
        per_fold[source] = {"constants": folds[source].as_dict(), "held_out": band_table(own, errors)}
        held_out += errors
        ordered += own
    from racer.shared.sim.car.dynamics import CAR_DYNAMICS

    shipped = folds["all files"]
    return {
        "study": "console2020-fit",
        "log": str(log),
        "segments": {"fit": len(fit_segments), "report": len(report_segments)},
        "folds": per_fold,
        "held_out": band_table(ordered, held_out),
        "all_episodes": {
            "constants": shipped.as_dict(),
            "in_sample": band_table(report_segments, replay(route, dynamics_of(shipped), report_segments)),
        },
        "baselines_same_segments": {
            name: band_table(report_segments, replay(route, CAR_DYNAMICS[name], report_segments))
            for name in BASELINE_PROFILES
        },
    }


@click.command(name="console2020-fit")
@click.option("--log", type=click.Path(exists=True, dir_okay=False, path_type=Path), default=LOG, show_default=True)
@click.option("--route", type=click.Path(exists=True, dir_okay=False, path_type=Path), default=ROUTE, show_default=True)
def console2020_fit_command(log: Path, route: Path) -> None:
    """Fit the 2019 generation's car on the 2020 console log leaving one episode out; one JSON line."""
    click.echo(json.dumps(run_fit(log, route, progress=True)))
