"""The replay limits' command: per speed band, what the logs allow any car model in `python -m benchmarks fidelity`."""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path

import click
import numpy as np

from benchmarks.fidelity.simtrace_replay import SPEED_BANDS_MPS, Segment, band_label, load_replayable, replay_files
from research import route_option, simtraces_option
from research.replay_limits.heading_floor import heading_floor_deg
from research.replay_limits.noise import in_progress_rows, oracle_start_errors_m, replay_floor_m, row_timing
from research.tyre_fit.twin import CarConstants


def band_medians(segments: Sequence[Segment], values: Sequence[float | None], digits: int) -> dict[str, float]:
    """The median of `values` (one per segment; None left out) per speed band of the segments' start speed."""
    medians = {}
    for low, high in SPEED_BANDS_MPS:
        members = [
            value
            for segment, value in zip(segments, values, strict=True)
            if value is not None and low <= segment.start_speed_mps < high
        ]
        if members:
            medians[band_label(low, high)] = round(float(np.median(members)), digits)
    return medians


def run_limits(simtraces: Sequence[Path]) -> dict:
    """Per band, the medians after 1 s of: the leave-one-file-out heading predictor's error (heading_floor.py), the
    twin replayed from a start state fitted to the next logged poses, and an exact twin replayed on its own pseudo-log
    with the files' row-timing jitter (noise.py); and the row timing itself."""
    segments = load_replayable(simtraces)
    constants = CarConstants()
    result: dict = {
        "segments": len(segments),
        "files": len(simtraces),
        "heading_floor_deg_1s_median": band_medians(segments, heading_floor_deg(segments, 1.0), 2),
        "oracle_start_m_1s_median": band_medians(segments, oracle_start_errors_m(segments, constants).tolist(), 4),
    }
    try:
        timing = row_timing(in_progress_rows(simtraces))
    except ValueError as exc:
        return {**result, "row_timing": str(exc)}
    floor = replay_floor_m(segments, constants, timing.unexplained_jitter_s)
    result["replay_floor_m_1s_median"] = band_medians(segments, floor.tolist(), 4)
    result["row_timing"] = {
        "rows": timing.rows,
        "step_s": round(timing.step_s, 4),
        "tstamp_share": round(timing.tstamp_share, 3),
        "unexplained_jitter_s": round(timing.unexplained_jitter_s, 4),
    }
    return result


@click.command(name="replay-limits")
@simtraces_option
@route_option
def replay_limits_command(simtraces: Path, route: Path) -> None:
    """What the real logs allow the open-loop replay, per speed band; one JSON line."""
    click.echo(json.dumps(run_limits(replay_files(simtraces, route))))
