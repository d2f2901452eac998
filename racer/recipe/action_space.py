"""The action space the line needs: its (commanded speed, steering) at every control step, clustered into discrete
actions within DeepRacer on AWS's limits, or the bounds of a continuous space.

Every step's need is a commanded speed and a lateral acceleration (left or right). Two needs closer than the
tolerances are one action: in speed, what the drive changes in one control period (brake limit × 1/15 s, in command
units); in lateral acceleration, the margin the held line keeps below the tyres' peak (`line_needs.HELD_SLIP`): an
action off by more would spend all of it. The clusters (k-means on the needs scaled by the tolerances, fewest that
put every step within one tolerance of an action, scipy) become actions turning both ways (a policy that
corrects a drift needs the other side too), each steering the steady turn of its cluster's centre. Three more let the
car recover: straight at the top speed, and the line's largest steering both ways at its speed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.cluster.vq import kmeans2

from racer.recipe.line_needs import HELD_SLIP, STEP_S, LineNeeds, steady_steering_deg, step_samples
from racer.shared.deepracer.model_metadata import (
    MAX_DISCRETE_ACTIONS,
    MAX_SPEED_MPS,
    MAX_STEERING_ANGLE_DEG,
    MIN_CONTINUOUS_SPEED_MPS,
    MIN_SPEED_MPS,
)
from racer.shared.sim.car.dynamics import CarDynamics

SPEED_STEP_MPS = 0.1
"""Speeds are written to DeepRacer on AWS's console step."""
STEERING_STEP_DEG = 0.1
"""Steering to a tenth of a degree: at 4 m/s a whole degree is more than a tolerance (docs/racing.md)."""
CLUSTER_SEED = 0
"""k-means++ draws its first centres: a fixed seed makes the same line give the same actions."""


@dataclass(frozen=True)
class Action:
    steering_deg: float
    speed_mps: float
    """Commanded, as DeepRacer's action space holds it."""


@dataclass(frozen=True)
class DiscreteSpace:
    actions: tuple[Action, ...]
    clusters: int
    worst_distance: float
    """The farthest step's distance to its cluster in tolerances (≤ 1 unless the action limit stopped the search)."""
    speed_tolerance_mps: float
    accel_tolerance_mps2: float

    def to_json(self) -> list[dict]:
        return [
            {"steering_angle": a.steering_deg, "speed": a.speed_mps, "index": i} for i, a in enumerate(self.actions)
        ]


def tolerances(needs: LineNeeds) -> tuple[float, float]:
    """(speed in command m/s, lateral acceleration in m/s²) below which two needs are one action."""
    speed = needs.held.brake_accel_mps2 * STEP_S / needs.rolling_ratio
    accel = needs.held.lateral_accel_mps2 / math.tanh(HELD_SLIP) - needs.held.lateral_accel_mps2
    return speed, accel


def discrete_space(needs: LineNeeds, dynamics: CarDynamics) -> DiscreteSpace:
    """The fewest clusters that hold every step within one tolerance, as actions (see the module docstring)."""
    commands, accels, _ = step_samples(needs)
    speed_tol, accel_tol = tolerances(needs)
    scaled = np.column_stack((commands / speed_tol, np.abs(accels) / accel_tol))
    recover = _recovery_actions(needs.commands_mps, needs.steering_deg)
    best: tuple[tuple[Action, ...], int, float] | None = None
    for count in range(1, len(scaled) + 1):
        centres, worst = _clusters(scaled, count)
        actions = _dedupe(
            recover[:1] + _cluster_actions(centres * (speed_tol, accel_tol), needs, dynamics) + recover[1:]
        )
        if len(actions) > MAX_DISCRETE_ACTIONS:
            break
        best = (actions, count, worst)
        if worst <= 1.0:
            break
    assert best is not None  # one cluster gives at most 5 actions
    return DiscreteSpace(best[0], best[1], round(best[2], 3), speed_tol, accel_tol)


def continuous_space(needs: LineNeeds) -> dict:
    """Bounds from the line's slowest command to the top speed, and its largest steering both ways."""
    low = max(math.floor(needs.commands_mps.min() / SPEED_STEP_MPS) * SPEED_STEP_MPS, MIN_CONTINUOUS_SPEED_MPS)
    lock = min(float(math.ceil(np.abs(needs.steering_deg).max())), MAX_STEERING_ANGLE_DEG)
    return {"steering_angle": {"low": -lock, "high": lock}, "speed": {"low": round(low, 1), "high": MAX_SPEED_MPS}}


def _clusters(scaled: np.ndarray, count: int) -> tuple[np.ndarray, float]:
    """k-means centres of the scaled needs and the largest distance of a need to its centre."""
    if count == 1:
        centres = scaled.mean(axis=0, keepdims=True)
    else:
        centres, _ = kmeans2(scaled, count, iter=50, minit="++", seed=np.random.default_rng(CLUSTER_SEED))
    distance = np.linalg.norm(scaled[:, None, :] - centres[None, :, :], axis=2).min(axis=1)
    return centres, float(distance.max())


def _cluster_actions(centres: np.ndarray, needs: LineNeeds, dynamics: CarDynamics) -> list[Action]:
    """Each centre (command, |lateral acceleration|) as the steady turn at its speed, both ways, slowest last."""
    actions: list[Action] = []
    for command, accel in sorted(centres.tolist(), reverse=True):
        ground = max(command, MIN_SPEED_MPS) * needs.rolling_ratio
        angle = float(steady_steering_deg(np.array([accel / ground**2]), np.array([ground]), dynamics,
                                          needs.held.world)[0])  # fmt: skip
        angle = min(angle, MAX_STEERING_ANGLE_DEG)
        actions += [_action(angle, command), _action(-angle, command)]
    return actions


def _recovery_actions(commands: np.ndarray, steering: np.ndarray) -> list[Action]:
    """Straight at the top speed; the line's largest steering (of all its stations), both ways, at the speed it is
    needed at."""
    widest = int(np.argmax(np.abs(steering)))
    angle = abs(float(steering[widest]))
    return [_action(0.0, MAX_SPEED_MPS), _action(angle, commands[widest]), _action(-angle, commands[widest])]


def _action(steering_deg: float, command_mps: float) -> Action:
    speed = min(max(round(command_mps / SPEED_STEP_MPS) * SPEED_STEP_MPS, MIN_SPEED_MPS), MAX_SPEED_MPS)
    steering = round(steering_deg / STEERING_STEP_DEG) * STEERING_STEP_DEG
    clipped = min(max(steering, -MAX_STEERING_ANGLE_DEG), MAX_STEERING_ANGLE_DEG)
    return Action(round(clipped, 1) + 0.0, round(speed, 1))  # + 0.0: no -0.0 in the file


def _dedupe(actions: list[Action]) -> tuple[Action, ...]:
    seen: dict[tuple[float, float], Action] = {}
    for action in actions:
        seen.setdefault((action.steering_deg, action.speed_mps), action)
    return tuple(seen.values())
