"""A scripted stand-in for the network: follows the centre line and leaves the track at planned places.

It steers by pure pursuit on the env's own track geometry (read through the driver's env), so laps are reliable and
the exits happen where the plan says: `exits[lap_index]` lists progress values (%) at which the car turns off the
track once each. An exit is over when the env has put the car back (or ended the lap attempt).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np

from racer.shared.deepracer.model_metadata import ModelMetadata, parse_model_metadata

CONTINUOUS_METADATA: ModelMetadata = parse_model_metadata(
    {
        "action_space": {"steering_angle": {"low": -30.0, "high": 30.0}, "speed": {"low": 0.5, "high": 3.0}},
        "action_space_type": "continuous",
        "sensor": ["FRONT_FACING_CAMERA"],
        "neural_network": "DEEP_CONVOLUTIONAL_NETWORK_SHALLOW",
        "training_algorithm": "clipped_ppo",
        "version": "5",
    },
    source="scripted test metadata",
)
LOOKAHEAD_M = 0.6


class ScriptedPolicy:
    """`.act(observation, greedy, generator, epsilon)` like ActorCritic, for a continuous [steering, speed] space."""

    def __init__(
        self,
        speed_mps: float = 2.0,
        exits: Mapping[int, Sequence[float]] | None = None,
        shortcut_m: float | None = None,
    ) -> None:
        """`shortcut_m`: an exit does not turn right off the road but heads straight for the centre-line point that
        many metres further on, across the infield (a corner cut)."""
        self.speed_mps = speed_mps
        self.shortcut_m = shortcut_m
        self.exits = {lap: sorted(values) for lap, values in (exits or {}).items()}
        self._shortcut_target: tuple[float, float] | None = None
        self.driver = None
        self.done: set[tuple[int, float]] = set()
        self._exit: tuple[int, float, int] | None = None
        self.calls = 0

    def attach(self, driver) -> None:
        self.driver = driver

    def _progress_pct(self, env, x: float, y: float) -> float:
        return 100.0 * env.track.project_normalized(x, y)

    def act(self, observation, greedy, generator=None, epsilon=0.0):
        assert greedy, "evaluation must act greedily"
        self.calls += 1
        driver = self.driver
        env = driver.core
        pose = env.car.pose(env.data)
        mx, my = pose.model_point
        progress = self._progress_pct(env, mx, my)
        lap = driver.lap_index
        if self._exit is not None:
            exit_lap, _, resets_at_start = self._exit
            if lap != exit_lap or driver.lap_resets > resets_at_start:
                self._exit = None
                self._shortcut_target = None
        if self._exit is None:
            for threshold in self.exits.get(lap, ()):
                if (lap, threshold) not in self.done and progress >= threshold:
                    self.done.add((lap, threshold))
                    self._exit = (lap, threshold, driver.lap_resets)
                    break
        track = env.track
        ndist = track.project_normalized(mx, my)
        ahead = (ndist + LOOKAHEAD_M / track.length_m) % 1.0
        tx, ty, yaw = track.pose_at(ahead, "center")
        if self._exit is not None and self.shortcut_m is not None:
            if self._shortcut_target is None:
                target = (ndist + self.shortcut_m / track.length_m) % 1.0
                self._shortcut_target = track.pose_at(target, "center")[:2]
            tx, ty = self._shortcut_target
        elif self._exit is not None:
            # Aim well outside the road, to the right of the driving direction.
            tx += 3.0 * math.sin(yaw)
            ty -= 3.0 * math.cos(yaw)
        heading_error = math.atan2(ty - pose.origin_y_m, tx - pose.origin_x_m) - pose.yaw_rad
        heading_error = (heading_error + math.pi) % (2 * math.pi) - math.pi
        steering_deg = max(-30.0, min(30.0, math.degrees(heading_error) * 1.5))
        # Slow down in the bends so the follower never leaves the road on its own.
        speed = self.speed_mps * (1.0 - 0.5 * abs(steering_deg) / 30.0)
        action = np.array([steering_deg / 30.0, (speed - 1.75) / 1.25], dtype=np.float32)
        return action, 0.0
