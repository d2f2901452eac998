"""What the logs themselves allow: the real rows' timing noise, and the replay error of a car model that is exact.

`python -m benchmarks fidelity` compares racer's car with real simtraces whose rows are not evenly timed: the SimApp's
Gazebo runs on while the agent thinks, a row's pose is a cached model state and its `tstamp` a clock callback.
These measures bound what any car model can reach on these logs:

* `row_timing`: at a held speed command, how much of the per-row distance's spread the logged step lengths
  explain (`tstamp_share`: 1 = the tstamps are the true step lengths, 0 = pure noise), and the step-length jitter
  the tstamps miss (upper bound: all unexplained spread of the distance counted as timing);
* `replay_floor_m`: the planar twin (research/tyre_fit/twin.py) with fixed constants plays the real car. Its trajectory from
  one row before each segment's start, with the logged commands and the replay's 1/15 s steps plus that jitter,
  becomes a pseudo-log; the replay's own protocol (central-difference start state from the pseudo-log's poses,
  hinges at the previous command, 1/15 s steps) then runs the same twin on it. The error left is the protocol's
  and the noise's alone: a floor for the replay's figures;
* `oracle_start_errors_m`: the replay from a start state (forward and lateral speed, yaw rate, hinge angle) fitted
  to the next logged poses, which no replay may know: what a perfect estimate of the unlogged start state could
  gain at most.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from racer.shared.deepracer.simtrace import read_simtrace
from racer.shared.sim.car.vehicle import Car
from research.tyre_fit.twin import CarConstants, SegmentBatch, position_errors_m, simulate

if TYPE_CHECKING:
    from benchmarks.fidelity.simtrace_replay import Segment

HELD_ROWS_BEFORE = 4
HELD_ROWS_AFTER = 9
"""A row counts for `row_timing` when the speed command is the same from 4 rows before it to 9 rows after: the
speed has settled and the local median is taken over steady rows."""


@dataclass(frozen=True)
class RowTiming:
    rows: int
    step_s: float
    """Median logged step length."""
    tstamp_share: float
    """Regression slope of the relative per-row distance on the relative logged step length (1 = fully explained)."""
    unexplained_jitter_s: float
    """Spread of the per-row distance the logged step lengths do not explain, as step-length jitter (upper bound)."""


def in_progress_rows(paths: Iterable[Path]) -> list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]:
    """(x, y, tstamp, speed command) of each episode's `in_progress` rows in real simtrace files."""
    episodes = []
    for path in paths:
        rows = read_simtrace(Path(path).read_bytes(), source=str(path))
        for _, group in rows.groupby("episode", sort=False):
            group = group[group.episode_status == "in_progress"]
            episodes.append(tuple(group[c].to_numpy(dtype=np.float64) for c in ("X", "Y", "tstamp", "throttle")))
    return episodes


def row_timing(episodes: Sequence[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]) -> RowTiming:
    """From (x, y, tstamp, speed command) per episode's `in_progress` rows. Pose k holds at tstamp[k-1]
    (simtrace_replay.py), so the distance from pose k to k+1 is driven during tstamp[k-1] .. tstamp[k]."""
    distance_dev, step_dev, steps = [], [], []
    for x, y, tstamp, speed in episodes:
        distance = np.hypot(np.diff(x), np.diff(y))
        step = np.diff(tstamp)
        for k in range(HELD_ROWS_BEFORE, len(distance) - HELD_ROWS_AFTER):
            window = slice(k - HELD_ROWS_BEFORE, k + HELD_ROWS_AFTER + 1)
            if not np.all(speed[window] == speed[k]):
                continue
            local_distance = np.median(distance[k - 2 : k + HELD_ROWS_AFTER])
            local_step = np.median(step[k - 3 : k + HELD_ROWS_AFTER - 1])
            if local_distance <= 0 or local_step <= 0:
                continue
            distance_dev.append(distance[k] / local_distance - 1.0)
            step_dev.append(step[k - 1] / local_step - 1.0)
            steps.append(local_step)
    if len(steps) < 20:
        raise ValueError(f"row_timing needs ≥ 20 rows at a held speed command, found {len(steps)}")
    d, s = np.asarray(distance_dev), np.asarray(step_dev)
    share = float(np.dot(s, d) / np.dot(s, s))
    residual = d - share * s
    step_s = float(np.median(steps))
    return RowTiming(len(steps), step_s, share, float(np.std(residual)) * step_s)


def _central_state(origin_xy: np.ndarray, yaw: np.ndarray, times_s: np.ndarray, index: int) -> np.ndarray:
    """(n, 6) state of the car origin at pose `index` from poses index±1: x, y, yaw, forward, lateral, yaw rate."""
    dt = times_s[:, index + 1] - times_s[:, index - 1]
    vx = (origin_xy[:, index + 1, 0] - origin_xy[:, index - 1, 0]) / dt
    vy = (origin_xy[:, index + 1, 1] - origin_xy[:, index - 1, 1]) / dt
    heading = yaw[:, index]
    cos_h, sin_h = np.cos(heading), np.sin(heading)
    yaw_rate = (yaw[:, index + 1] - yaw[:, index - 1]) / dt
    return np.stack(
        [
            origin_xy[:, index, 0],
            origin_xy[:, index, 1],
            heading,
            cos_h * vx + sin_h * vy,
            cos_h * vy - sin_h * vx,
            yaw_rate,
        ],
        axis=1,
    )


def replay_floor_m(
    segments: Sequence[Segment],
    constants: CarConstants,
    jitter_s: float,
    horizon_s: float = 1.0,
    seed: int = 0,
) -> np.ndarray:
    """Per segment, the position error (m) after `horizon_s` of replaying an exact twin on its own pseudo-log."""
    batch = SegmentBatch.of(segments)
    rows = batch.steer_rad.shape[1]
    times = np.concatenate([np.zeros((len(segments), 1)), np.cumsum(batch.step_s, axis=1)], axis=1)
    yaw = np.stack([np.unwrap(np.pad(s.yaw_rad, (0, rows - len(s.yaw_rad)), mode="edge")) for s in segments])
    ahead = Car.FRONT_OF_CAR_M
    origin = batch.model_xy - ahead * np.stack([np.cos(yaw), np.sin(yaw)], axis=2)
    # The truth starts one pose earlier (pose 1, from the logged poses 0 and 2): shift every row by one.
    rng = np.random.default_rng(seed)
    truth_steps = (
        np.maximum(batch.step_s + rng.normal(0.0, jitter_s, batch.step_s.shape), 0.01) if jitter_s else batch.step_s
    )
    truth = replace(
        batch,
        start=_central_state(origin, yaw, times, 1),
        steer_rad=np.roll(batch.steer_rad, 1, axis=1),
        speed_mps=np.roll(batch.speed_mps, 1, axis=1),
        step_s=np.roll(truth_steps, 1, axis=1),
    )
    xs, ys, yaws = simulate(truth, constants)  # poses 1 .. rows-2 of the segment
    pseudo_xy = batch.model_xy.copy()
    pseudo_xy[:, 1 : 1 + xs.shape[1]] = np.stack([xs, ys], axis=2)
    pseudo_yaw = yaw.copy()
    pseudo_yaw[:, 1 : 1 + xs.shape[1]] = yaws
    pseudo_origin = pseudo_xy - ahead * np.stack([np.cos(pseudo_yaw), np.sin(pseudo_yaw)], axis=2)
    pseudo_log = replace(batch, start=_central_state(pseudo_origin, pseudo_yaw, times, 2), model_xy=pseudo_xy)
    rx, ry, _ = simulate(pseudo_log, constants)
    usable = rx.shape[1] - 1  # the truth's last pose is one short of the segment's
    if np.any(np.argmin(np.abs(pseudo_log.elapsed_s - horizon_s), axis=1) >= usable):
        raise ValueError(f"segments are too short for a {horizon_s:g} s floor")
    return position_errors_m(pseudo_log, rx, ry, horizon_s)


ORACLE_FIT_ROWS = 8
"""Poses after the start the oracle's start state is fitted to (≈ 0.5 s)."""
YAW_WEIGHT_M = 0.1
"""A heading error weighs in the oracle's fit as the sideways shift it makes 0.1 m ahead."""


def oracle_start_errors_m(
    segments: Sequence[Segment],
    constants: CarConstants,
    fit_rows: int = ORACLE_FIT_ROWS,
    horizon_s: float = 1.0,
    iterations: int = 6,
) -> np.ndarray:
    """Per segment, the position error after `horizon_s` when the start's forward and lateral speed, yaw rate and
    hinge angle are fitted (Gauss-Newton, all segments at once) to the front of car and heading of the next
    `fit_rows` poses."""
    batch = SegmentBatch.of(segments)
    short = replace(
        batch,
        steer_rad=batch.steer_rad[:, : fit_rows + 3],
        speed_mps=batch.speed_mps[:, : fit_rows + 3],
        step_s=batch.step_s[:, : fit_rows + 2],
        elapsed_s=batch.elapsed_s[:, : fit_rows + 1],
        model_xy=batch.model_xy[:, : fit_rows + 3],
    )
    rows = batch.steer_rad.shape[1]
    yaw = np.stack([np.unwrap(np.pad(s.yaw_rad, (0, rows - len(s.yaw_rad)), mode="edge")) for s in segments])
    # Front of car (m) and heading (as the sideways shift 0.1 m ahead) at poses 1 .. fit_rows after the start.
    logged = np.concatenate(
        [short.model_xy[:, 3 : 3 + fit_rows].reshape(len(segments), -1), YAW_WEIGHT_M * yaw[:, 3 : 3 + fit_rows]],
        axis=1,
    )
    params = np.column_stack([batch.start[:, 3:6], batch.steer_rad[:, 1]])
    steps = (0.01, 0.01, 0.02, 0.005)  # m/s, m/s, rad/s, rad

    def residual(values: np.ndarray) -> np.ndarray:
        start = batch.start.copy()
        start[:, 3:6] = values[:, :3]
        xs, ys, yaws = simulate(replace(short, start=start), constants, start_steer_rad=values[:, 3])
        points = np.stack([xs[:, 1 : 1 + fit_rows], ys[:, 1 : 1 + fit_rows]], axis=2).reshape(len(segments), -1)
        return np.concatenate([points, YAW_WEIGHT_M * yaws[:, 1 : 1 + fit_rows]], axis=1) - logged

    for _ in range(iterations):
        base = residual(params)
        jacobian = np.stack(
            [(residual(params + np.eye(4)[i] * step) - base) / step for i, step in enumerate(steps)], axis=2
        )
        normal = np.einsum("nmi,nmj->nij", jacobian, jacobian) + 1e-6 * np.eye(4)
        params = params - np.linalg.solve(normal, np.einsum("nmi,nm->ni", jacobian, base)[..., None])[..., 0]
    start = batch.start.copy()
    start[:, 3:6] = params[:, :3]
    oracle = replace(batch, start=start)
    xs, ys, _ = simulate(oracle, constants, start_steer_rad=params[:, 3])
    return position_errors_m(oracle, xs, ys, horizon_s)
