"""One rollout worker's world and episode settings, and how they map onto DeepRacer's training_params.yaml keys.

The keys of a model folder (where these settings are stored, per worker) live in racer.shared.model_layout.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

from racer.shared.sim.car.dynamics import CarDynamics, car_profile
from racer.shared.sim.config import DEFAULT_TRACK
from racer.shared.sim.generations.catalog import DEFAULT_GENERATION, generation
from racer.shared.sim.objects.challenge import ChallengeConfig
from racer.shared.sim.scene.worlds import WORLD_NAMES as WORLDS
from racer.shared.sim.tracks.catalog import world_name_for_direction

__all__ = ["SETTING", "Setting", "WorkerSettings", "setting"]

SETTING = "racer.setting"
"""The key of a WorkerSettings field's metadata that holds its `Setting`."""


def _flag(params: Mapping[str, object], name: str, default: object, source: str) -> bool:
    raw = str(params.get(name, default)).strip().lower()
    if raw not in {"true", "false", "1", "0"}:
        raise ValueError(f"{name}: {params[name]!r} is not True or False")
    return raw in {"true", "1"}


def _whole(params: Mapping[str, object], name: str, default: object, source: str) -> int:
    number = float(params.get(name, default))  # type: ignore[arg-type]
    if not number.is_integer():
        raise ValueError(f"{name}: {params[name]!r} is not a whole number")
    return int(number)


Reader = Callable[[Mapping[str, object], str, Any, str], Any]
"""How a training_params value is read: (params, key, the field's default, source) -> the field's value."""
FLAG: Reader = _flag
"""True/False (DeepRacer's spelling; also true/false, 1/0)."""
WHOLE: Reader = _whole
"""A whole number, also written as 3.0."""
INTEGER: Reader = lambda params, name, default, source: int(params.get(name, default))  # noqa: E731
NUMBER: Reader = lambda params, name, default, source: float(params.get(name, default))  # noqa: E731
TEXT: Reader = lambda params, name, default, source: str(params.get(name, default))  # noqa: E731
LOWER: Reader = lambda params, name, default, source: str(params.get(name, default)).lower()  # noqa: E731
TEXT_OR_DEFAULT: Reader = lambda params, name, default, source: str(params.get(name) or default).strip()  # noqa: E731
"""Text where an empty value means the default."""
CHALLENGE: Reader = lambda params, name, default, source: ChallengeConfig.from_training_params(params)  # noqa: E731
"""RACE_TYPE and the obstacle / bot-car keys (shared/sim/objects/challenge.py)."""

_SAME = "<same name>"


@dataclass(frozen=True)
class Setting:
    """Where a WorkerSettings field comes from and goes to."""

    key: str
    """Its training_params.yaml key (DeepRacer's name, or racer's RACER_*)."""
    read: Reader
    env: str | None
    """The `EnvConfig` field it sets; None: the worker itself uses it (evaluation trials, best-model metric)."""
    to_env: Callable[[Any], Any] | None = None
    """Its value as the EnvConfig field wants it (a car profile name -> its CarDynamics); None: as it is."""

    def env_field(self, name: str) -> str | None:
        """The EnvConfig field of the WorkerSettings field `name`."""
        return name if self.env == _SAME else self.env


def setting(
    default: Any,
    key: str,
    read: Reader,
    env: str | None = _SAME,
    to_env: Callable[[Any], Any] | None = None,
) -> Any:
    """A WorkerSettings field: its default, training_params key, reader and EnvConfig field (default: the field's own
    name, `Setting.env_field`)."""
    return field(default=default, metadata={SETTING: Setting(key, read, env, to_env)})


@dataclass(frozen=True)
class WorkerSettings:
    """One rollout worker's world and episode settings (DeepRacer-for-Cloud's worker-N.env).

    Each field names its training_params key, how the key is read and the `EnvConfig` field it sets (`setting()`):
    `to_training_params`, `from_training_params` and racer.shared.run_settings.env_config follow these, so a new
    setting is one field here."""

    world: str = setting("base", "RACER_WORLD", TEXT)
    """Surface and look: base, carpet, concrete or wood."""
    track: str = setting(DEFAULT_TRACK, "WORLD_NAME", TEXT)
    """Route name (WORLD_NAME: looked up on the route search path, RACER_ROUTES_PATH then tracks/) or a path to a
    DeepRacer .npy route file. TRACK_DIRECTION_CLOCKWISE appends `_cw`/`_ccw` as DeepRacer-on-AWS does."""
    reverse_dir: bool = setting(False, "REVERSE_DIR", FLAG)
    alternate_driving_direction: bool = setting(False, "ALTERNATE_DRIVING_DIRECTION", FLAG)
    change_start_position: bool = setting(True, "CHANGE_START_POSITION", FLAG)
    round_robin_advance_dist: float = setting(0.05, "ROUND_ROBIN_ADVANCE_DIST", NUMBER)
    start_position_offset: float = setting(0.0, "START_POSITION_OFFSET", NUMBER)
    min_eval_trials: int = setting(5, "MIN_EVAL_TRIALS", INTEGER, env=None)
    """Greedy evaluation episodes per checkpoint (worker 0 only)."""
    best_model_metric: str = setting("progress", "BEST_MODEL_METRIC", LOWER, env=None)
    """progress, reward or laptime: how deepracer_checkpoints.json picks the best checkpoint."""
    number_of_resets: int = setting(0, "NUMBER_OF_RESETS", WHOLE)
    """NUMBER_OF_RESETS: pause-and-resets per episode before a reset rule ends it (SimApp training default 0)."""
    off_track_penalty_s: float = setting(0.0, "OFF_TRACK_PENALTY", NUMBER)
    """OFF_TRACK_PENALTY (also for `reversed`): seconds paused per reset; the SimApp's training default is 0."""
    collision_penalty_s: float = setting(0.0, "COLLISION_PENALTY", NUMBER)
    """COLLISION_PENALTY; training default 0 as in the SimApp."""
    number_of_reverse_counts: int = setting(15, "NUMBER_OF_REVERSE_COUNTS", WHOLE)
    """NUMBER_OF_REVERSE_COUNTS: steps of decreasing progress that make `reversed` (SimApp ReverseResetRule)."""
    eval_spread_starts: bool = setting(False, "RACER_EVAL_SPREAD_STARTS", FLAG, env=None)
    """racer's option (training_params key RACER_EVAL_SPREAD_STARTS): evaluation trial i of n starts i/n of a lap
    further on. DeepRacer starts them all at one place; in a deterministic simulator they would all be the same
    drive, so spread starts make "3 of 3 laps" mean three different laps. A spread start within 1 m of an object
    takes the lane away from it, as a training start does (the SimApp's start line never has a box on it)."""
    eval_max_steps: int = setting(0, "RACER_EVAL_MAX_STEPS", WHOLE, env=None)
    """racer's option (training_params key RACER_EVAL_MAX_STEPS): an in-training evaluation episode ends after this
    many steps (0: no cap but DeepRacer's 100,000). A barely trained greedy policy may circle without leaving the
    track, and worker 0 plays such an episode to the end before it reads the trainer's next announcement; a cap of a
    few laps' steps keeps short runs (tests, quick trials) from waiting minutes for it."""
    eval_continuous: bool = setting(False, "RACER_EVAL_CONTINUOUS", FLAG, env=None)
    """racer's option (training_params key RACER_EVAL_CONTINUOUS): the MIN_EVAL_TRIALS evaluation trials are the laps
    of one run, as DeepRacer's continuous evaluation (IS_CONTINUOUS) drives them: each crossing of the line closes a
    lap and the next goes on at speed; the first reset rule (off track, reversed, ...) ends the run, so every lap it
    completed is a lap without a reset. One run has one start (RACER_EVAL_SPREAD_STARTS spreads nothing) and
    RACER_EVAL_MAX_STEPS caps the whole run. `python -m benchmarks race-pace` judges three consecutive laps this way."""
    domain_randomization: bool = setting(False, "ENABLE_DOMAIN_RANDOMIZATION", FLAG)
    """ENABLE_DOMAIN_RANDOMIZATION: random light colours and attenuation at every episode, as the SimApp."""
    car_randomization: bool = setting(False, "RACER_CAR_RANDOMIZATION", FLAG)
    """racer's RACER_CAR_RANDOMIZATION: tint, brightness, camera blur, noise and pose jitter per episode."""
    dynamics_randomization: bool = setting(False, "RACER_DYNAMICS_RANDOMIZATION", FLAG)
    """racer's RACER_DYNAMICS_RANDOMIZATION: every training episode a car drawn around one generation's car
    (both axles' stiffness, yaw inertia, steering servo, a 0-1 step command delay;
    shared/sim/car/dynamics_randomization.py)."""
    generation: str = setting(DEFAULT_GENERATION, "RACER_GENERATION", TEXT_OR_DEFAULT)
    """racer's RACER_GENERATION: the DeepRacer simulator the worker stands in for, its look and car together
    (`generations.GENERATIONS`: 2019, simapp5, simapp6)."""
    car_profile: str = setting("", "RACER_CAR_PROFILE", TEXT_OR_DEFAULT, env="car_dynamics",
                               to_env=lambda name: car_profile(name) if name else None)  # fmt: skip
    """racer's RACER_CAR_PROFILE: a car (`car.dynamics.CAR_DYNAMICS`) instead of the generation's; "" = the
    generation's car."""
    simapp_dir: str = setting("", "RACER_SIMAPP_DIR", TEXT_OR_DEFAULT, to_env=lambda text: Path(text) if text else None)
    """racer's RACER_SIMAPP_DIR: a SimApp bundle/ folder on the worker's machine whose world meshes and textures
    the camera draws instead of racer's look ("" = racer's look)."""
    challenge: ChallengeConfig = setting(ChallengeConfig(), "RACE_TYPE", CHALLENGE)
    """RACE_TYPE and the obstacle / bot-car keys (shared/sim/objects/challenge.py)."""

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
        if self.eval_max_steps < 0:
            raise ValueError(f"RACER_EVAL_MAX_STEPS must be >= 0 (0: no cap), got {self.eval_max_steps}")
        if self.off_track_penalty_s < 0 or self.collision_penalty_s < 0:
            raise ValueError("OFF_TRACK_PENALTY and COLLISION_PENALTY must be >= 0 seconds")
        generation(self.generation)  # an unknown name: ValueError naming RACER_GENERATION and the valid names
        if self.car_profile:
            car_profile(self.car_profile)  # an unknown name: ValueError naming RACER_CAR_PROFILE and the valid names

    @property
    def car_dynamics(self) -> CarDynamics:
        """The car this worker drives (`EnvConfig.car_dynamics`): its car profile's, else its generation's."""
        return car_profile(self.car_profile) if self.car_profile else generation(self.generation).car

    def to_training_params(self, model_prefix: str, num_workers: int) -> dict[str, object]:
        """DeepRacer's training_params.yaml keys, values strings as DeepRacer-for-Cloud writes them (OBJECT_POSITIONS,
        when set, a list of "ndist,lane" strings as in DeepRacer's yaml)."""
        challenge = self.challenge.to_training_params()
        params: dict[str, object] = {
            "JOB_TYPE": "TRAINING",
            "WORLD_NAME": self.track,
            "RACER_WORLD": self.world,
            "RACE_TYPE": challenge.pop("RACE_TYPE"),
            "SAGEMAKER_SHARED_S3_PREFIX": model_prefix,
            "NUM_WORKERS": str(num_workers),
        }
        for item in fields(self):
            if item.name not in {"world", "track", "challenge"}:
                value = getattr(self, item.name)
                params[item.metadata[SETTING].key] = value if isinstance(value, str) else str(value)
        return {**params, **challenge}

    @classmethod
    def from_training_params(cls, params: Mapping[str, object], source: str) -> WorkerSettings:
        clockwise = (
            _flag(params, "TRACK_DIRECTION_CLOCKWISE", False, source) if "TRACK_DIRECTION_CLOCKWISE" in params else None
        )
        values: dict[str, object] = {}
        try:
            for item in fields(cls):
                spec: Setting = item.metadata[SETTING]
                values[item.name] = spec.read(params, spec.key, item.default, source)
            values["track"] = world_name_for_direction(str(values["track"]), clockwise)
            return cls(**values)
        except ValueError as error:
            raise ValueError(f"{source}: {error}") from error

    def replace(self, **changes) -> WorkerSettings:
        values = {f.name: getattr(self, f.name) for f in fields(self)}
        values.update({k: v for k, v in changes.items() if v is not None})
        return WorkerSettings(**values)
