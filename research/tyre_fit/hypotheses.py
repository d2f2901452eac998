"""The replay's protocol varied, one assumption at a time, with the fit's twin (`python -m research.tyre_fit
--hypotheses`).

Each variant changes how the logs are read, not the car: when a row's command starts to act (a late or early
action), which step lengths drive the replay (DeepRacer's nominal 1/15 s, the logged `tstamp`s, their median),
and which start state it begins from (central differences around the start pose, backward differences from the
rows before it only, or an oracle fitted to the next 0.5 s of the log). The twin keeps the shipped constants;
README.md gives these figures and, for the variants that could help, the same after refitting the constants.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from research.replay_limits.noise import oracle_start_errors_m
from research.tyre_fit.twin import FIT_HORIZONS_S, CarConstants, SegmentBatch, position_errors_m, simulate

if TYPE_CHECKING:
    from benchmarks.fidelity.simtrace_replay import Segment


def step_lengths(batch: SegmentBatch, base: str) -> np.ndarray:
    """Step lengths for `base`: "nominal" (the replay's 1/15 s), "tstamp" (logged), "median" (each segment's
    median logged step); zero in the padding, as `SegmentBatch.step_s`."""
    padding = batch.step_s == 0
    if base == "nominal":
        return batch.step_s
    if base == "tstamp":
        return batch.logged_step_s
    if base == "median":
        median = np.broadcast_to(np.median(batch.logged_step_s, axis=1, keepdims=True), batch.step_s.shape)
        return np.where(padding, 0.0, median)
    raise ValueError(f"unknown time base {base!r}: tstamp, median or nominal")


def start_states(segments: Sequence[Segment], times_s: np.ndarray, backward: bool) -> np.ndarray:
    """(n, 6) car-origin state at the start pose as `SegmentBatch.start`, from poses 1 and 3 (central) or 1 and 2
    (backward: the rows before the start only), at the given pose times."""
    after = 2 if backward else 3
    states = []
    for segment, times in zip(segments, times_s, strict=True):
        origin, yaw = segment.origin_xy, np.unwrap(segment.yaw_rad)
        dt = times[after] - times[1]
        vx, vy = (origin[after] - origin[1]) / dt
        cos_h, sin_h = np.cos(yaw[2]), np.sin(yaw[2])
        states.append(
            (
                origin[2, 0],
                origin[2, 1],
                yaw[2],
                cos_h * vx + sin_h * vy,
                cos_h * vy - sin_h * vx,
                (yaw[after] - yaw[1]) / dt,
            )
        )
    return np.array(states)


def _variant(
    segments: Sequence[Segment], batch: SegmentBatch, base: str, backward: bool
) -> tuple[SegmentBatch, np.ndarray]:
    steps = step_lengths(batch, base)
    times = np.concatenate([np.zeros((len(segments), 1)), np.cumsum(steps, axis=1)], axis=1)
    return replace(batch, step_s=steps, start=start_states(segments, times, backward)), times


VARIANTS: dict[str, dict] = {
    "as replayed": {},
    "command 1 row late": {"delay": 1.0},
    "command 0.5 row late": {"delay": 0.5},
    "command 0.25 row early": {"delay": -0.25},
    "time base: logged tstamps": {"base": "tstamp"},
    "time base: median logged step": {"base": "median"},
    "start: backward differences": {"backward": True},
}


def screen(segments: Sequence[Segment], bands: Sequence[tuple[float, float]], label: Callable) -> dict[str, dict]:
    """Per variant: the fit's loss (mean position error at 0.5, 1 and 1.5 s, summed) and per band the median
    position error after 1 s (m), all with the shipped constants; plus the oracle start state."""
    batch = SegmentBatch.of(segments)
    constants = CarConstants()
    speeds = np.array([segment.start_speed_mps for segment in segments])

    def per_band(errors: np.ndarray) -> dict[str, float]:
        return {
            label(low, high): round(float(np.median(errors[(speeds >= low) & (speeds < high)])), 4)
            for low, high in bands
            if np.any((speeds >= low) & (speeds < high))
        }

    table: dict[str, dict] = {}
    for name, options in VARIANTS.items():
        varied, _ = _variant(segments, batch, options.get("base", "nominal"), options.get("backward", False))
        xs, ys, _ = simulate(varied, constants, command_delay_rows=options.get("delay", 0.0))
        loss = sum(float(np.mean(position_errors_m(varied, xs, ys, h))) for h in FIT_HORIZONS_S)
        table[name] = {
            "loss_m": round(loss, 4),
            "position_m_1s_median": per_band(position_errors_m(varied, xs, ys, 1.0)),
        }
    table["start: oracle fitted to the next 0.5 s"] = {
        "position_m_1s_median": per_band(oracle_start_errors_m(segments, constants))
    }
    return table
