"""Multi-car races (HEAD_TO_MODEL, F1): several models on the track at once, each with its own policy, env and camera.

Every car drives its own `DeepRacerEnv` through its own `EvaluationDriver` (so each car's simtrace, metrics and videos
are written as `racer evaluate` writes them); the envs step in lockstep, one step of every racing car per tick, and
before each tick every env is handed the other cars where they are (`peer_cars.PeerCars`): its camera and LIDAR see
them and the SimApp's crash test and fault rule apply between cars. A car's frame shows the others at the start of the
tick (up to 1/15 s old); the crash test judges all cars at the same instant.

The SimApp's rules (deepracer-simapp v6.0.5 `bundle/markov/`):
* Single-file start (`track_geom/utils.py` `get_start_positions`, `track_geom/constants.py` START_POS_OFFSET 0.75 m;
  `agent_ctrl/rollout_agent_ctrl.py` `_start_lane_`): car i starts i x START_POS_OFFSET behind the line, even cars on
  the outer lane, odd cars on the inner lane. Progress counts from the line, so a car behind it starts with negative
  progress and its first lap is longer by its place on the grid.
* Laps: the cars run DeepRacer's continuous evaluation (IS_CONTINUOUS, NUMBER_OF_TRIALS = the laps;
  `reset/rules/episode_complete_reset_rule.py`): a car is done after its last lap, or when a rule fires with its reset
  budget used up.
* DONE_CONDITION (`evaluation_worker.py`, `utils.str_to_done_condition`; default `any`): `any` ends the race for all
  when the first car is done (head-to-model), `all` runs until every car is done (F1).
* Parking (F1, `agent_ctrl/rollout_agent_ctrl.py` `_park_car_model`, PARK_POSITIONS): with DONE_CONDITION `all` a car
  that completes its last lap goes to the PARK phase and is moved to a park position off the track; racer moves it out
  of the scene (its body goes to the scene's park spot), so the others neither see nor hit it. A car whose reset budget
  ran out is not parked: it stays where it stopped, an obstacle the others see and can hit.
* Crashes between cars: see `peer_cars`; the car at fault pauses for COLLISION_PENALTY where it is.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

from racer.evaluation_worker.driver import PENALTY_STATUSES, EvaluationDriver
from racer.evaluation_worker.laps import LapCallback, LapResult, LapTally
from racer.shared.deepracer.episode_status import EpisodeStatus
from racer.shared.sim.objects.peer_cars import PeerCars, PeerState
from racer.shared.sim.tracks.track import compute_progress

START_POS_OFFSET_M = 0.75
"""deepracer-simapp v6.0.5 `bundle/markov/track_geom/constants.py` START_POS_OFFSET: the gap between grid places."""
MULTI_CAR_RACE_TYPES = ("HEAD_TO_MODEL", "F1")
DONE_CONDITIONS = ("any", "all")


class MultiCarError(ValueError):
    """A multi-car race that cannot run as asked."""


@dataclass(frozen=True)
class MultiCarRules:
    race_type: str = "HEAD_TO_MODEL"
    laps: int = 1
    """NUMBER_OF_TRIALS of the continuous run: the laps each car races."""
    start_pos_offset_m: float = START_POS_OFFSET_M
    done_condition: str | None = None
    """`any` or `all`; None: `all` for F1 (its cars park), `any` for HEAD_TO_MODEL (the SimApp's default)."""
    max_race_s: float = 600.0
    """Simulated seconds after which the race stops whatever is left (a car stuck for good)."""

    def __post_init__(self) -> None:
        if self.race_type not in MULTI_CAR_RACE_TYPES:
            raise MultiCarError(f"RACE_TYPE: {self.race_type!r} is not one of {', '.join(MULTI_CAR_RACE_TYPES)}")
        if self.laps < 1:
            raise MultiCarError(f"laps: {self.laps} must be >= 1")
        if not 0.0 <= self.start_pos_offset_m <= 1.0:  # the SimApp clamps START_POS_OFFSET to [0, 1]
            raise MultiCarError(f"START_POS_OFFSET: {self.start_pos_offset_m} m is outside [0, 1]")
        if self.done_condition is not None and self.done_condition not in DONE_CONDITIONS:
            raise MultiCarError(f"DONE_CONDITION: {self.done_condition!r} is not 'any' or 'all'")

    @property
    def waits_for_all(self) -> bool:
        return (self.done_condition or ("all" if self.race_type == "F1" else "any")) == "all"


@dataclass(frozen=True)
class CarRun:
    """One car's race."""

    index: int
    laps: tuple[LapResult, ...]
    finished: bool
    """All laps completed."""
    finish_time_s: float | None
    """Sim time of the last lap's end (the crossing), for finishers."""
    parked: bool
    raced_pct: float
    """Distance raced from the line, in percent of a lap, when the car stopped."""

    @property
    def laps_completed(self) -> int:
        return sum(1 for lap in self.laps if lap.completed)

    @property
    def crash_count(self) -> int:
        return sum(lap.crash_count for lap in self.laps)


@dataclass(frozen=True)
class MultiCarResult:
    rules: MultiCarRules
    cars: tuple[CarRun, ...]
    finishing_order: tuple[int, ...]
    """Car indices: finishers by finish time (ties: grid order), then the others by distance raced."""


class _Car:
    """The loop's state of one car."""

    def __init__(self, index: int, driver: EvaluationDriver, peers: PeerCars) -> None:
        self.index = index
        self.driver = driver
        self.peers = peers
        self.laps: list[LapResult] = []
        self.tally: LapTally | None = None
        self.state = "racing"  # racing | done | parked
        self.progress = 0.0
        self.collidable = True
        self.finish_time_s: float | None = None
        self.speed_mps = 0.0
        self.final_raced_pct = 0.0

    def snapshot(self) -> PeerState:
        core = self.driver.core
        pose = core.car.pose(core.data)
        progress = self.progress
        if self.state == "racing":  # where the car's next step will judge it (its env computes the same value)
            ndist = core.track.project_normalized(*pose.model_point)
            progress = compute_progress(ndist, core.start_ndist, self.progress)
        # While racing every closed lap is a completed one (a continuous run).
        raced = 100.0 * len(self.laps) + progress if self.state == "racing" else self.final_raced_pct
        return PeerState(
            self.index,
            pose.origin_x_m,
            pose.origin_y_m,
            pose.yaw_rad,
            self.speed_mps,
            raced,
            collidable=self.collidable and self.state != "parked",
            on_track=self.state != "parked",
        )

    def close_lap(self, on_lap: LapCallback | None) -> LapResult | None:
        if self.tally is None or self.tally.last is None:
            return None
        lap = self.tally.result(trial=len(self.laps) + 1)
        self.laps.append(lap)
        self.tally = None
        if on_lap is not None:
            on_lap(lap)
        return lap

    def stop(self, state: str) -> None:
        completed = sum(1 for lap in self.laps if lap.completed)
        partial = self.laps[-1].progress_pct if self.laps and not self.laps[-1].completed else 0.0
        self.final_raced_pct = 100.0 * completed + partial
        self.state = state
        self.collidable = state != "parked"


def _start_grid(cars: Sequence[_Car], rules: MultiCarRules) -> None:
    """Every car on the line's episode, then moved to its grid place (car i: i x START_POS_OFFSET behind, even cars
    outer lane, odd inner). The reset's observation only chooses the prepare step's action, which is not driven."""
    for car in cars:
        start_time_s = car.driver.start_lap(0)
        car.tally = LapTally(0, start_time_s)
        core = car.driver.core
        track = core.track
        ndist = core.start_ndist - car.index * rules.start_pos_offset_m / track.length_m
        core.teleport(*track.pose_at(ndist, "inner" if car.index % 2 else "outer"))


def run_multi_car(
    drivers: Sequence[EvaluationDriver],
    peer_cars: Sequence[PeerCars],
    rules: MultiCarRules,
    on_lap: Sequence[LapCallback] | None = None,
    on_tick: Callable[[Sequence[PeerState], float], None] | None = None,
) -> MultiCarResult:
    """Race the cars (driver i drives car i, its env built with `peer_cars[i]`) and return each car's laps.
    `on_tick(snapshot, sim_time_s)` sees every car where each tick starts (the all-cars top view draws it)."""
    if len(drivers) < 2 or len(drivers) != len(peer_cars):
        raise MultiCarError(f"{rules.race_type} needs two or more cars, each with its env's PeerCars")
    cars = [_Car(i, d, p) for i, (d, p) in enumerate(zip(drivers, peer_cars, strict=True))]
    callbacks = list(on_lap) if on_lap is not None else [None] * len(cars)
    _start_grid(cars, rules)
    race_over = False
    while not race_over:
        snapshot = [car.snapshot() for car in cars]
        if on_tick is not None:
            on_tick(snapshot, max(car.driver.sim_time_s for car in cars))
        racing = [car for car in cars if car.state == "racing"]
        for car in racing:
            car.peers.update(snapshot)
            car.peers.own_laps_done = len(car.laps)
        for car in racing:
            if _step(car, rules, callbacks[car.index]):
                race_over = race_over or not rules.waits_for_all
        if all(car.state != "racing" for car in cars):
            race_over = True
        if max(car.driver.sim_time_s for car in cars) >= rules.max_race_s:  # car 0 may have parked
            race_over = True
    for car in cars:
        if car.state == "racing":
            car.close_lap(callbacks[car.index])
            car.stop("done")
    runs = tuple(
        CarRun(
            car.index,
            tuple(car.laps),
            car.finish_time_s is not None,
            car.finish_time_s,
            car.state == "parked",
            car.final_raced_pct,
        )
        for car in cars
    )
    return MultiCarResult(rules, runs, finishing_order(runs))


def _step(car: _Car, rules: MultiCarRules, on_lap: LapCallback | None) -> bool:
    """One step of one car; True when the car is done (its last lap, or a rule beyond its reset budget)."""
    driver = car.driver
    outcome = driver.step()
    crossing = outcome.status == EpisodeStatus.LAP_COMPLETE
    last_lap = len(car.laps) + 1 >= rules.laps
    assert car.tally is not None
    if crossing and not last_lap:
        record = driver.record(outcome, status=EpisodeStatus.IN_PROGRESS, done=False)
    else:
        record = driver.record(outcome)
    car.tally.add(record)
    row = record.row
    car.progress = 0.0 if crossing else float(row["progress"])
    car.speed_mps = float(row["throttle"])
    status = str(row["episode_status"])
    pausing = (status in PENALTY_STATUSES and not row["done"]) or (
        status == EpisodeStatus.PAUSE and float(row["pause_duration"]) > 1e-9
    )
    car.collidable = not pausing
    if not (crossing or outcome.terminated or outcome.truncated):
        return False
    car.close_lap(on_lap)
    if crossing and not last_lap:
        driver.continue_after_lap(len(car.laps), outcome.sim_time_s, clear_reset_budget=False)
        car.tally = LapTally(len(car.laps), outcome.sim_time_s)
        return False
    if crossing:
        car.finish_time_s = outcome.sim_time_s
        car.stop("parked" if rules.waits_for_all else "done")
    else:
        car.stop("done")
    return True


def finishing_order(cars: Sequence[CarRun]) -> tuple[int, ...]:
    """Finishers by finish time (ties: grid order), then the rest by distance raced (more first), then grid order."""
    finishers = sorted((c for c in cars if c.finished), key=lambda c: (c.finish_time_s, c.index))
    others = sorted((c for c in cars if not c.finished), key=lambda c: (-c.raced_pct, c.index))
    return tuple(c.index for c in (*finishers, *others))
