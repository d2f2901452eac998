"""One rollout worker's world and episode settings, and how they map onto DeepRacer's training_params.yaml keys.

The keys of a model folder (where these settings are stored, per worker) live in racer.shared.model_layout.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, fields

from racer.shared.sim.car_dynamics import DEFAULT_CAR_PROFILE, CarDynamics, car_profile
from racer.shared.sim.config import DEFAULT_TRACK
from racer.shared.sim.race_config import RaceConfig
from racer.shared.sim.track_catalog import world_name_for_direction
from racer.shared.sim.worlds import WORLD_NAMES as WORLDS

__all__ = ["WorkerSettings", "default_worker_settings"]


@dataclass(frozen=True)
class WorkerSettings:
    """One rollout worker's world and episode settings (DeepRacer-for-Cloud's worker-N.env)."""

    world: str = "base"
    """Surface and look: base, carpet, concrete or wood."""
    track: str = DEFAULT_TRACK
    """Route name (WORLD_NAME: looked up on the route search path, RACER_ROUTES_PATH then tracks/) or a path to a
    DeepRacer .npy route file. TRACK_DIRECTION_CLOCKWISE appends `_cw`/`_ccw` as DeepRacer-on-AWS does."""
    reverse_dir: bool = False
    alternate_driving_direction: bool = False
    change_start_position: bool = True
    round_robin_advance_dist: float = 0.05
    start_position_offset: float = 0.0
    min_eval_trials: int = 5
    """Greedy evaluation episodes per checkpoint (worker 0 only)."""
    best_model_metric: str = "progress"
    """progress, reward or laptime: how deepracer_checkpoints.json picks the best checkpoint."""
    number_of_resets: int = 0
    """NUMBER_OF_RESETS: pause-and-resets per episode before a reset rule ends it (SimApp training default 0)."""
    off_track_penalty_s: float = 0.0
    """OFF_TRACK_PENALTY (also for `reversed`): seconds paused per reset; the SimApp's training default is 0."""
    collision_penalty_s: float = 0.0
    """COLLISION_PENALTY; training default 0 as in the SimApp."""
    number_of_reverse_counts: int = 15
    """NUMBER_OF_REVERSE_COUNTS: steps of decreasing progress that make `reversed` (SimApp ReverseResetRule)."""
    eval_spread_starts: bool = False
    """racer's option (training_params key RACER_EVAL_SPREAD_STARTS): evaluation trial i of n starts i/n of a lap
    further on. DeepRacer starts them all at one place; in a deterministic simulator they would all be the same
    drive, so spread starts make "3 of 3 laps" mean three different laps. A spread start within 1 m of an object
    takes the lane away from it, as a training start does (the SimApp's start line never has a box on it)."""
    domain_randomization: bool = False
    """ENABLE_DOMAIN_RANDOMIZATION: random light colours and attenuation at every episode, as the SimApp."""
    car_randomization: bool = False
    """racer's RACER_CAR_RANDOMIZATION: tint, brightness, camera blur, noise and pose jitter per episode."""
    dynamics_randomization: bool = False
    """racer's RACER_DYNAMICS_RANDOMIZATION: a car drawn around the profile every episode (tyres, yaw inertia,
    steering servo, rolling radius, a 0-1 step command delay; shared/sim/dynamics_randomization.py)."""
    car_profile: str = DEFAULT_CAR_PROFILE
    """racer's RACER_CAR_PROFILE: the car's dynamics, one of `car_dynamics.CAR_DYNAMICS` (gazebo, simtrace-fit)."""
    simapp_dir: str = ""
    """racer's RACER_SIMAPP_DIR: a SimApp bundle/ folder on the worker's machine whose world meshes and textures
    the camera draws instead of racer's look ("" = racer's look)."""
    race: RaceConfig = RaceConfig()
    """RACE_TYPE and the obstacle / bot-car keys (shared/sim/race_config.py)."""

    def __post_init__(self) -> None:
        if self.world not in WORLDS:
            raise ValueError(f"world {self.world!r} is not one of {', '.join(WORLDS)}")
        if self.best_model_metric not in {"progress", "reward", "laptime"}:
            raise ValueError(f"BEST_MODEL_METRIC {self.best_model_metric!r} is not progress, reward or laptime")
        if not 0.0 <= self.round_robin_advance_dist <= 1.0:
            raise ValueError(f"ROUND_ROBIN_ADVANCE_DIST {self.round_robin_advance_dist} is outside [0, 1]")
        if self.number_of_resets < 0 or self.number_of_reverse_counts < 1:
            raise ValueError(
                f"NUMBER_OF_RESETS must be >= 0 and NUMBER_OF_REVERSE_COUNTS >= 1, got "
                f"{self.number_of_resets} and {self.number_of_reverse_counts}"
            )
        if self.off_track_penalty_s < 0 or self.collision_penalty_s < 0:
            raise ValueError("OFF_TRACK_PENALTY and COLLISION_PENALTY must be >= 0 seconds")
        car_profile(self.car_profile)  # an unknown name: ValueError naming RACER_CAR_PROFILE and the valid names

    @property
    def car_dynamics(self) -> CarDynamics:
        """The dynamics of this worker's car profile (`EnvConfig.car_dynamics`)."""
        return car_profile(self.car_profile)

    def to_training_params(self, model_prefix: str, num_workers: int) -> dict[str, object]:
        """DeepRacer's training_params.yaml keys, values strings as DeepRacer-for-Cloud writes them (OBJECT_POSITIONS,
        when set, a list of "ndist,lane" strings as in DeepRacer's yaml)."""
        race = self.race.to_training_params()
        return {
            "JOB_TYPE": "TRAINING",
            "WORLD_NAME": self.track,
            "RACER_WORLD": self.world,
            "RACE_TYPE": race.pop("RACE_TYPE"),
            "SAGEMAKER_SHARED_S3_PREFIX": model_prefix,
            "NUM_WORKERS": str(num_workers),
            "REVERSE_DIR": str(self.reverse_dir),
            "ALTERNATE_DRIVING_DIRECTION": str(self.alternate_driving_direction),
            "CHANGE_START_POSITION": str(self.change_start_position),
            "ROUND_ROBIN_ADVANCE_DIST": str(self.round_robin_advance_dist),
            "START_POSITION_OFFSET": str(self.start_position_offset),
            "MIN_EVAL_TRIALS": str(self.min_eval_trials),
            "BEST_MODEL_METRIC": self.best_model_metric,
            "NUMBER_OF_RESETS": str(self.number_of_resets),
            "OFF_TRACK_PENALTY": str(self.off_track_penalty_s),
            "COLLISION_PENALTY": str(self.collision_penalty_s),
            "NUMBER_OF_REVERSE_COUNTS": str(self.number_of_reverse_counts),
            "RACER_EVAL_SPREAD_STARTS": str(self.eval_spread_starts),
            "ENABLE_DOMAIN_RANDOMIZATION": str(self.domain_randomization),
            "RACER_CAR_RANDOMIZATION": str(self.car_randomization),
            "RACER_DYNAMICS_RANDOMIZATION": str(self.dynamics_randomization),
            "RACER_CAR_PROFILE": self.car_profile,
            "RACER_SIMAPP_DIR": self.simapp_dir,
            **race,
        }

    @classmethod
    def from_training_params(cls, params: Mapping[str, object], source: str) -> WorkerSettings:
        def whole(name: str, default: int) -> int:
            number = float(params.get(name, default))
            if not number.is_integer():
                raise ValueError(f"{name}: {params[name]!r} is not a whole number")
            return int(number)

        def flag(name: str, default: bool) -> bool:
            raw = str(params.get(name, default)).strip().lower()
            if raw not in {"true", "false", "1", "0"}:
                raise ValueError(f"{source}: {name}: {params[name]!r} is not True or False")
            return raw in {"true", "1"}

        defaults = cls()
        clockwise = flag("TRACK_DIRECTION_CLOCKWISE", False) if "TRACK_DIRECTION_CLOCKWISE" in params else None
        try:
            return cls(
                world=str(params.get("RACER_WORLD", defaults.world)),
                track=world_name_for_direction(str(params.get("WORLD_NAME", defaults.track)), clockwise),
                reverse_dir=flag("REVERSE_DIR", defaults.reverse_dir),
                alternate_driving_direction=flag("ALTERNATE_DRIVING_DIRECTION", defaults.alternate_driving_direction),
                change_start_position=flag("CHANGE_START_POSITION", defaults.change_start_position),
                round_robin_advance_dist=float(
                    params.get("ROUND_ROBIN_ADVANCE_DIST", defaults.round_robin_advance_dist)
                ),
                start_position_offset=float(params.get("START_POSITION_OFFSET", defaults.start_position_offset)),
                min_eval_trials=int(params.get("MIN_EVAL_TRIALS", defaults.min_eval_trials)),
                best_model_metric=str(params.get("BEST_MODEL_METRIC", defaults.best_model_metric)).lower(),
                eval_spread_starts=flag("RACER_EVAL_SPREAD_STARTS", defaults.eval_spread_starts),
                number_of_resets=whole("NUMBER_OF_RESETS", defaults.number_of_resets),
                off_track_penalty_s=float(params.get("OFF_TRACK_PENALTY", defaults.off_track_penalty_s)),
                collision_penalty_s=float(params.get("COLLISION_PENALTY", defaults.collision_penalty_s)),
                number_of_reverse_counts=whole("NUMBER_OF_REVERSE_COUNTS", defaults.number_of_reverse_counts),
                domain_randomization=flag("ENABLE_DOMAIN_RANDOMIZATION", defaults.domain_randomization),
                car_randomization=flag("RACER_CAR_RANDOMIZATION", defaults.car_randomization),
                dynamics_randomization=flag("RACER_DYNAMICS_RANDOMIZATION", defaults.dynamics_randomization),
                car_profile=str(params.get("RACER_CAR_PROFILE") or defaults.car_profile).strip(),
                simapp_dir=str(params.get("RACER_SIMAPP_DIR") or defaults.simapp_dir),
                race=RaceConfig.from_training_params(params),
            )
        except ValueError as error:
            raise ValueError(f"{source}: {error}") from error

    def replace(self, **changes) -> WorkerSettings:
        values = {f.name: getattr(self, f.name) for f in fields(self)}
        values.update({k: v for k, v in changes.items() if v is not None})
        return WorkerSettings(**values)


def default_worker_settings(
    num_workers: int,
    track: str = DEFAULT_TRACK,
    worlds: tuple[str, ...] = WORLDS,
    domain_randomization: bool = False,
    car_randomization: bool = False,
    car_profile: str = DEFAULT_CAR_PROFILE,
    dynamics_randomization: bool = False,
) -> list[WorkerSettings]:
    """Worker i gets world i (cycling through `worlds`) on the same track."""
    return [
        WorkerSettings(
            world=worlds[i % len(worlds)],
            track=track,
            domain_randomization=domain_randomization,
            car_randomization=car_randomization,
            car_profile=car_profile,
            dynamics_randomization=dynamics_randomization,
        )
        for i in range(num_workers)
    ]
