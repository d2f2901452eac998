"""A policy wrapper for races: stops an entrant whose network returns NaN, and ends the run at maxTimeInMinutes.

The driver asks the policy for every step's action, so this is where a race can watch the entrant without
touching `racer evaluate`: `attach(driver)` gives it the simulated clock (`driver.sim_time_s`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np


class PolicyReturnedNaN(Exception):
    """The entrant's network produced NaN: it cannot drive."""


class RaceTimeLimit(Exception):
    """The simulated clock passed maxTimeInMinutes; the laps finished so far are the result."""


class PolicyGuard:
    def __init__(self, policy: Any, *, time_limit_s: float) -> None:
        self.policy = policy
        self.time_limit_s = time_limit_s
        self._driver: Any = None

    @property
    def config(self) -> Any:
        """The guarded policy's PolicyConfig (its stack_size decides what the driver feeds it)."""
        return getattr(self.policy, "config", None)

    def attach(self, driver: Any) -> None:
        self._driver = driver

    def act(
        self,
        observation: Mapping[str, np.ndarray],
        greedy: bool,
        generator: np.random.Generator | None = None,
        epsilon: float = 0.0,
    ) -> tuple[Any, float]:
        if self._driver is not None and self._driver.sim_time_s > self.time_limit_s:
            raise RaceTimeLimit(
                f"maxTimeInMinutes: the simulated clock passed {self.time_limit_s / 60.0:g} min "
                f"({self._driver.sim_time_s:.1f} s)"
            )
        action, log_prob = self.policy.act(observation, greedy, generator, epsilon)
        values = np.asarray(action, dtype=np.float64)
        if np.isnan(values).any() or (isinstance(log_prob, float) and math.isnan(log_prob)):
            raise PolicyReturnedNaN(
                "the policy returned NaN (the network's weights or inputs give no number): it cannot drive"
            )
        return action, log_prob
