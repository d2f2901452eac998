"""Drive the environment with a greedy policy, one step of the episode loop (racer.shared.episode_loop) at a time,
and hand every finished step to the recorders.

Both evaluation modes (DeepRacer trials, race rule) are written on top of this: they decide when a lap starts, how a
step's status is reported (an intermediate lap of a continuous run is `in_progress`, the race clock can turn a step
into `time_up`) and when to stop. The driver owns the policy call, the simtrace `episode` column and the recorders.

Continuing a run after a completed lap (continuous evaluation, race laps) needs the env to keep its episode open.
`DeepRacerEnv` ends the episode on `lap_complete`; `continue_after_lap` reopens it through the env's attributes
(see the module docstring of `racer.evaluation_worker` for the small env API that would replace this).
"""

from __future__ import annotations

import time
from collections import defaultdict
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from racer.shared.episode_loop import EpisodeLoop
from racer.shared.policy.protocol import Policy
from racer.shared.sim.env import DeepRacerEnv

PENALTY_STATUSES: tuple[str, ...] = ("crashed", "immobilized", "off_track", "reversed")
"""Statuses a reset rule produces; each such step counts once in EvaluationMetrics (`<status>_count`)."""


@dataclass(frozen=True)
class CarState:
    """Where the car was when the observation of a step was taken (before the step's action acted)."""

    origin_x_m: float
    origin_y_m: float
    yaw_rad: float
    sim_time_s: float


@dataclass(frozen=True)
class StepRecord:
    """One finished step, as written to the simtrace and handed to the recorders."""

    lap_index: int
    """0-based number of the lap (trial) the step belongs to: the simtrace `episode` column."""
    row: Mapping[str, Any]
    """The 19 simtrace columns of the step, as written."""
    action: Any
    reward: float
    observation: Mapping[str, np.ndarray]
    """The observation the action was chosen from."""
    car: CarState
    lap_resets: int
    """Put-backs used so far in the current lap (including this step's, if it is one)."""


@dataclass(frozen=True)
class StepOutcome:
    """The environment's answer to one step, before the mode has decided how to report it."""

    row: dict[str, Any]
    reward: float
    terminated: bool
    truncated: bool
    lap_time_s: float | None
    action: Any
    observation: Mapping[str, np.ndarray]
    car: CarState

    @property
    def status(self) -> str:
        return str(self.row["episode_status"])

    @property
    def progress_pct(self) -> float:
        return float(self.row["progress"])

    @property
    def sim_time_s(self) -> float:
        return float(self.row["tstamp"])


class StepObserver(Protocol):
    """A recorder (simtrace, video, MCAP). `before_step` sees the env at the pose of the coming step's row."""

    def before_step(self, env: DeepRacerEnv) -> None: ...

    def on_step(self, record: StepRecord) -> None: ...

    def close(self) -> None: ...


class EvaluationDriver:
    """Greedy policy + env + recorders. Modes call `start_lap`, `step`, `record`, `continue_after_lap`."""

    def __init__(
        self,
        env: DeepRacerEnv,
        policy: Policy,
        observers: Sequence[StepObserver] = (),
        seed: int = 0,
    ) -> None:
        self.env = env
        self.core: DeepRacerEnv = env.unwrapped  # type: ignore[assignment]
        self.policy = policy
        self.observers = tuple(observers)
        self._seed = seed
        self._loop = EpisodeLoop(policy, [env], [np.random.default_rng(seed)], greedy=True)
        """The episode loop every mode steps (racer.shared.episode_loop); observers see single frames."""
        self._pending: StepOutcome | None = None
        self._started = False
        self.lap_index = 0
        """Simtrace `episode` value of the coming steps; the mode sets it when a lap (trial) starts."""
        self.lap_resets = 0
        self.steps_total = 0
        self.observer_seconds: dict[str, float] = defaultdict(float)
        """Wall time spent in each recorder (by class name): what videos and recordings cost."""

    @property
    def sim_time_s(self) -> float:
        return float(self.core.data.time)

    def start_lap(self, lap_index: int) -> float:
        """Put the car on the start line (an evaluation episode: the start never moves). Returns the sim time.

        The first call seeds the env, which also sets the simulation clock to 0; later calls keep the clock running.
        """
        if self._pending is not None:
            raise RuntimeError("the previous step was not recorded")
        self._loop.reset(0, {"evaluation": True}, seed=None if self._started else self._seed)
        self._started = True
        self.lap_index = lap_index
        self.lap_resets = 0
        return self.sim_time_s

    def step(self) -> StepOutcome:
        """Choose the greedy action for the current observation and step the env. Call `record` next."""
        if not self._started:
            raise RuntimeError("start_lap() must come before step()")
        if self._pending is not None:
            raise RuntimeError("the previous step was not recorded")
        for observer in self.observers:
            started = time.perf_counter()
            observer.before_step(self.core)
            self.observer_seconds[type(observer).__name__] += time.perf_counter() - started
        pose = self.core.car.pose(self.core.data)
        car = CarState(pose.origin_x_m, pose.origin_y_m, pose.yaw_rad, self.sim_time_s)
        (step,) = self._loop.step([0], [0.0])
        self._pending = StepOutcome(
            row=step.info["simtrace"],
            reward=step.reward,
            terminated=step.terminated,
            truncated=step.truncated,
            lap_time_s=step.info.get("lap_time_s"),
            action=step.action,
            observation=step.observation,
            car=car,
        )
        return self._pending

    def record(self, outcome: StepOutcome, *, status: str | None = None, done: bool | None = None) -> StepRecord:
        """Finalise the step (optionally reporting another status/done, as DeepRacer does) and hand it on."""
        if outcome is not self._pending:
            raise RuntimeError("record() must get the outcome of the last step()")
        self._pending = None
        row = {**outcome.row, "episode": self.lap_index}
        if status is not None:
            row["episode_status"] = status
        if done is not None:
            row["done"] = bool(done)
        if row["episode_status"] in PENALTY_STATUSES and not row["done"]:
            self.lap_resets += 1
        self.steps_total += 1
        record = StepRecord(
            lap_index=self.lap_index,
            row=row,
            action=outcome.action,
            reward=outcome.reward,
            observation=outcome.observation,
            car=outcome.car,
            lap_resets=self.lap_resets,
        )
        for observer in self.observers:
            started = time.perf_counter()
            observer.on_step(record)
            self.observer_seconds[type(observer).__name__] += time.perf_counter() - started
        return record

    def continue_after_lap(self, lap_index: int, lap_end_time_s: float, *, clear_reset_budget: bool) -> None:
        """Keep driving after a completed lap without going back to the line (continuous run, race laps).

        DeepRacer's continuous mode keeps the episode running across the line: progress restarts from 0, the lap clock
        restarts at the crossing, the immobilized/reversed counters restart, and the reset budget is kept for the
        whole run (`clear_reset_budget=False`) or renewed per lap (the race rule).
        """
        self.core.continue_after_lap(lap_end_time_s, renew_reset_budget=clear_reset_budget)
        self.lap_index = lap_index
        self.lap_resets = 0

    def close(self) -> None:
        for observer in self.observers:
            started = time.perf_counter()
            observer.close()
            self.observer_seconds[type(observer).__name__] += time.perf_counter() - started


ProgressLog = Callable[[str], None]


def no_log(_line: str) -> None:
    """Default progress sink: silent."""
