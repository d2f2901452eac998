"""An entrant's best lap from its evaluation simtrace: positions, speed and sector times for the leaderboard page."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

SECTORS = 3
"""The lap split in three equal parts of progress, as DeepRacer's race broadcasts show sector times."""


def sector_times(progress: Sequence[float], tstamp: Sequence[float], start_s: float, sectors: int = SECTORS):
    """Seconds spent in each of `sectors` equal parts of the lap (None where the lap never reached its end)."""
    progress_a = np.asarray(progress, dtype=np.float64)
    time_a = np.asarray(tstamp, dtype=np.float64)
    times: list[float | None] = []
    previous = start_s
    for index in range(1, sectors + 1):
        boundary = 100.0 * index / sectors - 1e-9
        reached = np.nonzero(progress_a >= boundary)[0]
        if not len(reached):
            times.extend([None] * (sectors - index + 1))
            break
        at = float(time_a[reached[0]])
        times.append(round(at - previous, 3))
        previous = at
    return times


def best_lap_trace(simtrace_path: Path, laps: Sequence[Any]) -> dict[str, Any] | None:
    """The fastest completed lap's steps (x, y, speed from the positions) and sector times; None without one."""
    from racer.shared.deepracer.simtrace import read_simtrace

    completed = [lap for lap in laps if lap.lap_time_s is not None]
    if not completed or not Path(simtrace_path).is_file():
        return None
    best = min(completed, key=lambda lap: (lap.lap_time_s, lap.lap_index))
    frame = read_simtrace(simtrace_path)
    rows = frame[frame["episode"] == best.lap_index]
    x = rows["X"].to_numpy(dtype=np.float64)
    y = rows["Y"].to_numpy(dtype=np.float64)
    t = rows["tstamp"].to_numpy(dtype=np.float64)
    step = np.hypot(np.diff(x, prepend=x[:1]), np.diff(y, prepend=y[:1]))
    dt = np.diff(t, prepend=t[:1] - 1.0)
    speed = np.where(dt > 0, step / np.where(dt > 0, dt, 1.0), 0.0)
    return {
        "lap": best.lap_index + 1,
        "lap_time_s": round(best.lap_time_s, 3),
        "x": [round(v, 4) for v in x.tolist()],
        "y": [round(v, 4) for v in y.tolist()],
        "speed_mps": [round(v, 3) for v in speed.tolist()],
        "sector_times_s": sector_times(rows["progress"].tolist(), t.tolist(), best.start_time_s),
    }
