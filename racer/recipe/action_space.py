"""The action space the line needs: its (commanded speed, steering) at every control step, clustered into discrete
actions within DeepRacer on AWS's limits, or the bounds of a continuous space.

Every step's need is a commanded speed and a lateral acceleration (left or right). Two needs closer than the
tolerances are one action: in speed, what the drive changes in one control period (brake limit × 1/15 s, in command
units); in lateral acceleration, the margin the held line keeps below the tyres' peak (`line_needs.HELD_SLIP`): an
action off by more would spend all of it. The clusters (k-means on the needs scaled by the tolerances, fewest that
put every step within one tolerance of an action or of a mix of two, scipy) become actions turning both ways (a
policy that corrects a drift needs the other side too), each steering the steady turn of its cluster's centre. Three
more let the car recover: straight at the top speed, and the line's largest steering both ways at its speed.

A mix of two actions is a point on the segment between them: the car's drive and steering servo answer with a lag
(`simapp6`: 0.066 s each, one control period), so a policy that alternates two actions from frame to frame drives
between them, as DeepRacer's fast discrete models do on their way into and out of a corner. A first-order lag tau fed
a command that alternates every period dt swings ± half the two actions' difference × tanh(dt / 2 tau) about their
mean: two actions make a mix only while that swing stays within one tolerance (`mix_span`: 4.3 tolerances apart for
`simapp6`). A step's need farther than a tolerance from every action and every mix is one no action serves.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.cluster.vq import kmeans2

from racer.recipe.line_needs import (
    HELD_SLIP,
    STEP_S,
    LineNeeds,
    drive_time_constant_s,
    steady_steering_deg,
    step_samples,
)
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
CLUSTER_TRIES = 8
"""k-means minimises the mean distance, the rule asks for the largest: of this many draws, the one whose farthest step
is nearest."""


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
    """The farthest step's distance, in tolerances, to its nearest cluster or mix of two clusters (≤ 1 unless the
    action limit stopped the search)."""
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
    span = mix_span(dynamics)
    recover = _recovery_actions(needs.commands_mps, needs.steering_deg)
    best: tuple[tuple[Action, ...], int, float] | None = None
    for count in range(1, len(scaled) + 1):
        centres, worst = _clusters(scaled, count, span)
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


def mix_span(dynamics: CarDynamics) -> float:
    """How far apart (in tolerances) two actions may be for the car to drive their mix: the faster of its drive and
    servo lags swings ± half the span × tanh(dt / 2 tau) when they alternate every frame, at most one tolerance."""
    lag_s = min(drive_time_constant_s(dynamics), dynamics.steering_time_constant_s)
    return 2.0 / math.tanh(STEP_S / (2.0 * max(lag_s, 1e-9)))


def _clusters(scaled: np.ndarray, count: int, span: float) -> tuple[np.ndarray, float]:
    """k-means centres of the scaled needs and the largest distance of a need to its nearest centre or mix of two
    centres no more than `span` apart."""
    if count == 1:
        centres = scaled.mean(axis=0, keepdims=True)
        return centres, float(mix_distances(scaled, centres, span).max())
    rng = np.random.default_rng(CLUSTER_SEED)
    tries = [kmeans2(scaled, count, iter=50, minit="++", seed=rng)[0] for _ in range(CLUSTER_TRIES)]
    worst = [float(mix_distances(scaled, centres, span).max()) for centres in tries]
    best = int(np.argmin(worst))
    return tries[best], worst[best]


def mix_distances(points: np.ndarray, centres: np.ndarray, span: float) -> np.ndarray:
    """Each point's distance to the nearest of the centres and of the segments between two of them at most `span`
    apart."""
    distance = np.linalg.norm(points[:, None, :] - centres[None, :, :], axis=2).min(axis=1)
    for first in range(len(centres)):
        for second in range(first + 1, len(centres)):
            start, span_vector = centres[first], centres[second] - centres[first]
            if float(np.linalg.norm(span_vector)) > span:
                continue
            along = np.clip((points - start) @ span_vector / max(float(span_vector @ span_vector), 1e-12), 0, 1)
            nearest = start + along[:, None] * span_vector
            distance = np.minimum(distance, np.linalg.norm(points - nearest, axis=1))
    return distance


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
