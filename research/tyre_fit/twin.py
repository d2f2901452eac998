"""Fitting the car's dynamics constants to real simtraces: a planar twin of `tyres.py`, vectorised over segments.

The twin integrates the same equations as the MuJoCo car (tyre forces of `Tyres.apply`, a first-order steering
servo, the chassis' mass and yaw inertia) for all replay segments at once, so a Nelder-Mead fit of the nine
constants takes a minute where the MuJoCo replay would take hours. `python -m research.tyre_fit --fit all` prints the
constants fitted on all files (`car.dynamics.SIMTRACE_FIT_DYNAMICS` comes from it); `--fit leave-one-file-out` fits
on all files but one and replays that one in MuJoCo with the fold's constants, so the reported error is on data the
fit never saw.
The twin leaves out what MuJoCo adds (second-order hinge, the wheels' spin-up, the chassis' small roll and pitch):
README.md gives the twin's and MuJoCo's errors with the same constants.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Sequence
from dataclasses import asdict, dataclass, fields
from typing import TYPE_CHECKING

import numpy as np
from scipy.optimize import minimize

from racer.shared.sim.car.tyres import GRAVITY_MPS2, TyreParams
from racer.shared.sim.car.vehicle import (
    COMMAND_WHEEL_RADIUS_M,
    FRONT_AXLE_X_M,
    REAR_AXLE_X_M,
    STEERING_TIME_CONSTANT_S,
    TOTAL_MASS_KG,
    YAW_INERTIA_KGM2,
    Car,
    clip_command,
)
from racer.shared.sim.scene.worlds import get_world

if TYPE_CHECKING:
    from benchmarks.fidelity.simtrace_replay import Segment

FIT_HORIZONS_S = (0.5, 1.0, 1.5)
"""The fit minimises the mean front-of-car position error at these times after the start (a robust, smooth loss)."""
TWIN_SUBSTEPS = 8
"""Integration steps per logged row in the fit (the MuJoCo car takes 16; the twin's results differ by < 1 mm)."""


@dataclass(frozen=True)
class CarConstants:
    """What the fit adjusts: the tyre model plus the steering servo's time constant and the yaw inertia."""

    tyres: TyreParams = TyreParams()
    steering_time_constant_s: float = STEERING_TIME_CONSTANT_S
    yaw_inertia_kgm2: float = YAW_INERTIA_KGM2

    def vector(self) -> np.ndarray:
        return np.array([*asdict(self.tyres).values(), self.steering_time_constant_s, self.yaw_inertia_kgm2])

    @classmethod
    def from_vector(cls, values: Sequence[float]) -> CarConstants:
        names = [f.name for f in fields(TyreParams)]
        tyres = TyreParams(**{name: float(v) for name, v in zip(names, values, strict=False)})
        return cls(tyres, float(values[len(names)]), float(values[len(names) + 1]))

    def as_dict(self) -> dict[str, float]:
        return {
            **{k: round(v, 5) for k, v in asdict(self.tyres).items()},
            "steering_time_constant_s": round(self.steering_time_constant_s, 5),
            "yaw_inertia_kgm2": round(self.yaw_inertia_kgm2, 5),
        }


NEUTRAL = CarConstants(TyreParams(50.0, 50.0, 1.0, 1.0, 40.0, 22.0, 0.035, 0.3), 0.05, 0.078)
"""Where the leave-one-file-out folds start: round, physical guesses (the URDF's yaw inertia, the commanded speed,
axles that saturate at μ × load), not the defaults, which were fitted on every file including the held-out one."""
LOFO_EVALUATIONS = 700
"""From NEUTRAL, 800 evaluations on all files reach a loss 2.6 % above the defaults' (0.349 vs 0.340)."""
FIXED = ("min_slip_speed_mps",)
"""Constants the fit leaves alone (a numerical guard, not a property of the logs)."""


@dataclass(frozen=True)
class SegmentBatch:
    """Segments padded to one length: start states, commands, step lengths and the logged front-of-car track."""

    sources: np.ndarray
    start: np.ndarray
    """(n, 6): x, y, yaw, forward speed, lateral speed, yaw rate of the car origin at the start pose."""
    steer_rad: np.ndarray
    """(n, rows): clipped logged steering per row (row 1 is the command before the start)."""
    speed_mps: np.ndarray
    step_s: np.ndarray
    """(n, rows - 1): how long each row is replayed (fidelity.REPLAY_STEP_S; 0 in the padding)."""
    logged_step_s: np.ndarray
    """(n, rows - 1): the logged tstamp differences (for hypotheses.py)."""
    elapsed_s: np.ndarray
    """(n, poses): time of each compared pose after the start pose."""
    model_xy: np.ndarray

    @classmethod
    def of(cls, segments: Sequence[Segment]) -> SegmentBatch:
        rows = max(len(s.times_s) for s in segments)

        def padded(values: np.ndarray) -> np.ndarray:
            return np.pad(values, [(0, rows - len(values))] + [(0, 0)] * (values.ndim - 1), mode="edge")

        start, steer, speed = [], [], []
        for segment in segments:
            x, y, yaw, vx, vy, yaw_rate = segment.start_state()
            start.append((x, y, yaw, vx * math.cos(yaw) + vy * math.sin(yaw), vy * math.cos(yaw) - vx * math.sin(yaw)))
            start[-1] += (yaw_rate,)
            commands = [clip_command(v, s) for v, s in zip(segment.throttle_mps, segment.steer_deg, strict=True)]
            speed.append(padded(np.array([v for v, _ in commands])))
            steer.append(padded(np.radians([s for _, s in commands])))
        times = np.stack([padded(s.times_s) for s in segments])
        replay_times = np.stack([padded(s.replay_times_s) for s in segments])
        return cls(
            sources=np.array([s.source for s in segments]),
            start=np.array(start),
            steer_rad=np.stack(steer),
            speed_mps=np.stack(speed),
            step_s=np.diff(replay_times, axis=1),
            logged_step_s=np.diff(times, axis=1),
            elapsed_s=times[:, 2:] - times[:, 2:3],
            model_xy=np.stack([padded(s.model_xy) for s in segments]),
        )

    def subset(self, mask: np.ndarray) -> SegmentBatch:
        return SegmentBatch(**{f.name: getattr(self, f.name)[mask] for f in fields(self)})


def simulate(
    batch: SegmentBatch,
    constants: CarConstants,
    substeps: int = TWIN_SUBSTEPS,
    start_steer_rad: np.ndarray | None = None,
    command_delay_rows: float = 0.0,
) -> tuple[np.ndarray, ...]:
    """Front-of-car x, y and heading at every pose from the start (n, poses), as `CarReplay.run` computes them.
    The hinges start at the previous row's command unless `start_steer_rad` gives their angle. A row's command acts
    from its pose on; `command_delay_rows` shifts that (in rows, rounded to substeps; negative: earlier)."""
    delay = round(command_delay_rows * substeps)
    last_row = batch.steer_rad.shape[1] - 1
    p = constants.tyres
    front_arm, rear_arm = FRONT_AXLE_X_M, -REAR_AXLE_X_M
    weight = TOTAL_MASS_KG * GRAVITY_MPS2
    mu = get_world("base").tyre_friction  # DeepRacer's tyre μ, the world the replay drives in
    front_peak = p.front_peak_grip * mu * weight * rear_arm / (front_arm + rear_arm)
    rear_peak = p.rear_peak_grip * mu * weight * front_arm / (front_arm + rear_arm)
    x, y, yaw, forward, lateral, yaw_rate = (batch.start[:, i].copy() for i in range(6))
    steer = (batch.steer_rad[:, 1] if start_steer_rad is None else start_steer_rad).copy()
    ahead = Car.FRONT_OF_CAR_M
    xs, ys, yaws = [x + ahead * np.cos(yaw)], [y + ahead * np.sin(yaw)], [yaw.copy()]
    for k in range(2, batch.step_s.shape[1]):
        h = batch.step_s[:, k] / substeps
        follow = 1.0 - np.exp(-h / constants.steering_time_constant_s)
        for substep in range(substeps):
            row = min(max((k * substeps + substep - delay) // substeps, 0), last_row)
            target = batch.steer_rad[:, row]
            rolling = batch.speed_mps[:, row] * p.rolling_radius_m / COMMAND_WHEEL_RADIUS_M
            slip_speed = np.maximum(np.abs(forward), p.min_slip_speed_mps)
            front_slip = np.arctan2(lateral + front_arm * yaw_rate, slip_speed) - steer
            rear_slip = np.arctan2(lateral - rear_arm * yaw_rate, slip_speed)
            front = -front_peak * np.tanh(p.front_cornering_stiffness_n_per_rad * front_slip / front_peak)
            rear = -rear_peak * np.tanh(p.rear_cornering_stiffness_n_per_rad * rear_slip / rear_peak)
            drive = np.clip(
                p.drive_stiffness_n_per_mps * (rolling - forward), -p.max_drive_force_n, p.max_drive_force_n
            )
            fx = drive - front * np.sin(steer)
            fy = rear + front * np.cos(steer)
            torque = front_arm * front * np.cos(steer) - rear_arm * rear
            forward, lateral, yaw_rate = (
                forward + h * (fx / TOTAL_MASS_KG + lateral * yaw_rate),
                lateral + h * (fy / TOTAL_MASS_KG - forward * yaw_rate),
                yaw_rate + h * torque / constants.yaw_inertia_kgm2,
            )
            c, s = np.cos(yaw), np.sin(yaw)
            x, y, yaw = x + h * (c * forward - s * lateral), y + h * (s * forward + c * lateral), yaw + h * yaw_rate
            steer = steer + follow * (target - steer)
        xs.append(x + ahead * np.cos(yaw))
        ys.append(y + ahead * np.sin(yaw))
        yaws.append(yaw.copy())
    return np.stack(xs, axis=1), np.stack(ys, axis=1), np.stack(yaws, axis=1)


def position_errors_m(batch: SegmentBatch, xs: np.ndarray, ys: np.ndarray, horizon_s: float) -> np.ndarray:
    """Per segment, the distance between predicted and logged front of car at the pose nearest `horizon_s`."""
    k = np.argmin(np.abs(batch.elapsed_s[:, : xs.shape[1]] - horizon_s), axis=1)
    rows = np.arange(len(k))
    logged = batch.model_xy[rows, 2 + k]
    return np.hypot(xs[rows, k] - logged[:, 0], ys[rows, k] - logged[:, 1])


def loss(batch: SegmentBatch, constants: CarConstants, horizons_s: tuple[float, ...] = FIT_HORIZONS_S) -> float:
    xs, ys, _ = simulate(batch, constants)
    return float(sum(np.mean(position_errors_m(batch, xs, ys, h)) for h in horizons_s))


def fit(
    batch: SegmentBatch,
    start: CarConstants | None = None,
    evaluations: int = 600,
    progress: bool = False,
    fixed: tuple[str, ...] = FIXED,
    horizons_s: tuple[float, ...] = FIT_HORIZONS_S,
) -> CarConstants:
    """Nelder-Mead on the logarithms of the free constants (all positive), from `start` (the defaults); `fixed`
    names the constants kept at `start`'s values, `horizons_s` the times after the start the loss measures."""
    start = start or CarConstants()
    names = [*(f.name for f in fields(TyreParams)), "steering_time_constant_s", "yaw_inertia_kgm2"]
    free = np.array([name not in fixed for name in names])
    base = start.vector()

    def constants_of(z: np.ndarray) -> CarConstants:
        values = base.copy()
        values[free] = np.exp(z)
        return CarConstants.from_vector(values)

    calls = [0]

    def objective(z: np.ndarray) -> float:
        calls[0] += 1
        if progress and calls[0] % 100 == 0:
            print(f"fit: {calls[0]}/{evaluations} evaluations", file=sys.stderr, flush=True)
        return loss(batch, constants_of(z), horizons_s)

    result = minimize(
        objective, np.log(base[free]), method="Nelder-Mead", options={"maxfev": evaluations, "xatol": 1e-4}
    )
    return constants_of(result.x)


def leave_one_file_out(
    batch: SegmentBatch,
    evaluations: int = LOFO_EVALUATIONS,
    progress: bool = False,
    start: CarConstants = NEUTRAL,
    fixed: tuple[str, ...] = FIXED,
) -> dict[str, CarConstants]:
    """Per file, the constants fitted on all other files' segments, starting from `start` (NEUTRAL) with `fixed`
    kept at its values."""
    folds = {}
    for source in np.unique(batch.sources):
        held_out = batch.sources == source
        if held_out.all():
            raise ValueError(f"leave-one-file-out needs segments from at least two files; all are from {source}")
        if progress:
            print(f"fitting without {source}", file=sys.stderr, flush=True)
        folds[str(source)] = fit(batch.subset(~held_out), start, evaluations, progress, fixed)
    return folds
