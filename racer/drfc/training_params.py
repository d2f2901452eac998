"""Each worker's DeepRacer training_params, as DeepRacer-for-Cloud's `scripts/training/prepare-config.py` writes them.

prepare-config.py (deepracer-for-cloud 2eb1a1f1) builds worker 1's training_params from the environment with its own
defaults (WORLD_NAME LGSWide, RACE_TYPE TIME_TRIAL, six obstacles, ...). With multi-config, each further worker
starts from the previous worker's params and reads only the per-worker variables (`PER_WORKER_VARIABLES`) again:
some with a default, most without one (DRfC then writes null, on which the SimApp fails: racer refuses it, naming
the variable); the obstacle keys only when that worker's RACE_TYPE is OBJECT_AVOIDANCE, the bot-car keys only for
HEAD_TO_BOT, and they are dropped otherwise. Everything else (MIN_EVAL_TRIALS, BEST_MODEL_METRIC) is worker 1's.

`racer_params` then turns one worker's params into the training_params keys racer's WorkerSettings reads, checked,
with errors naming the DR_* variable and the line that set it.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from racer.drfc.experiment import DrfcExperiment, Env
from racer.drfc.shell_env import Assignment, DrfcFileError
from racer.drfc.worker_env import OBJECT_POSITIONS_VARIABLE
from racer.shared.worker_settings import WorkerSettings

__all__ = [
    "PER_WORKER_VARIABLES",
    "Param",
    "challenge_params",
    "experiment_worker_params",
    "racer_params",
    "worker_file_notes",
]


@dataclass(frozen=True)
class Param:
    """One training_params value and where it came from."""

    key: str
    variable: str
    value: str | None
    """None: unset with no default (DRfC writes null)."""
    origin: Assignment | None
    """None: prepare-config.py's default."""

    def describe(self) -> str:
        if self.origin is not None:
            return f"{self.origin.where}: {self.variable}={self.origin.value}"
        if self.value is None:
            return f"{self.variable} (not set)"
        return f"{self.variable} (not set: DRfC's default {self.value})"


Params = dict[str, Param]

OBSTACLE_VARIABLES: dict[str, tuple[str, str | None]] = {
    "NUMBER_OF_OBSTACLES": ("DR_OA_NUMBER_OF_OBSTACLES", "6"),
    "MIN_DISTANCE_BETWEEN_OBSTACLES": ("DR_OA_MIN_DISTANCE_BETWEEN_OBSTACLES", "2.0"),
    "RANDOMIZE_OBSTACLE_LOCATIONS": ("DR_OA_RANDOMIZE_OBSTACLE_LOCATIONS", "True"),
    "IS_OBSTACLE_BOT_CAR": ("DR_OA_IS_OBSTACLE_BOT_CAR", "false"),
    "OBSTACLE_TYPE": ("DR_OA_OBSTACLE_TYPE", "box_obstacle"),
}
"""training_params key -> (variable, worker 1's default in prepare-config.py)."""
BOT_CAR_VARIABLES: dict[str, tuple[str, str | None]] = {
    "IS_LANE_CHANGE": ("DR_H2B_IS_LANE_CHANGE", "False"),
    "LOWER_LANE_CHANGE_TIME": ("DR_H2B_LOWER_LANE_CHANGE_TIME", "3.0"),
    "UPPER_LANE_CHANGE_TIME": ("DR_H2B_UPPER_LANE_CHANGE_TIME", "5.0"),
    "LANE_CHANGE_DISTANCE": ("DR_H2B_LANE_CHANGE_DISTANCE", "1.0"),
    "NUMBER_OF_BOT_CARS": ("DR_H2B_NUMBER_OF_BOT_CARS", "0"),
    "MIN_DISTANCE_BETWEEN_BOT_CARS": ("DR_H2B_MIN_DISTANCE_BETWEEN_BOT_CARS", "2.0"),
    "RANDOMIZE_BOT_CAR_LOCATIONS": ("DR_H2B_RANDOMIZE_BOT_CAR_LOCATIONS", "False"),
    "BOT_CAR_SPEED": ("DR_H2B_BOT_CAR_SPEED", "0.2"),
    "PENALTY_SECONDS": ("DR_H2B_BOT_CAR_PENALTY", "2.0"),
}
WORKER_VARIABLES: dict[str, tuple[str, str | None]] = {
    "WORLD_NAME": ("DR_WORLD_NAME", None),
    "RACE_TYPE": ("DR_RACE_TYPE", None),
    "ALTERNATE_DRIVING_DIRECTION": ("DR_TRAIN_ALTERNATE_DRIVING_DIRECTION", None),
    "CHANGE_START_POSITION": ("DR_TRAIN_CHANGE_START_POSITION", None),
    "ROUND_ROBIN_ADVANCE_DIST": ("DR_TRAIN_ROUND_ROBIN_ADVANCE_DIST", None),
    "ENABLE_DOMAIN_RANDOMIZATION": ("DR_ENABLE_DOMAIN_RANDOMIZATION", None),
    "START_POSITION_OFFSET": ("DR_TRAIN_START_POSITION_OFFSET", "0.00"),
    "REVERSE_DIR": ("DR_TRAIN_REVERSE_DIRECTION", "False"),
}
"""What prepare-config.py reads again for workers 2 and up (key -> variable, default there)."""
PER_WORKER_VARIABLES: frozenset[str] = frozenset(
    {variable for variable, _ in (*WORKER_VARIABLES.values(), *OBSTACLE_VARIABLES.values(), *BOT_CAR_VARIABLES.values())}
    | {OBJECT_POSITIONS_VARIABLE, "DR_CAR_COLOR", "DR_CAR_BODY_SHELL_TYPE", "DR_CAMERA_MAIN_ENABLE",
       "DR_CAMERA_SUB_ENABLE", "DR_ENABLE_EXTRA_KVS_OVERLAY"}
)  # fmt: skip
"""The variables a worker-N.env may change (the rest of the file has no effect, in DRfC as in racer)."""

FLAG_KEYS = frozenset(
    {"REVERSE_DIR", "ALTERNATE_DRIVING_DIRECTION", "CHANGE_START_POSITION", "ENABLE_DOMAIN_RANDOMIZATION",
     "RANDOMIZE_OBSTACLE_LOCATIONS", "IS_OBSTACLE_BOT_CAR", "IS_LANE_CHANGE", "RANDOMIZE_BOT_CAR_LOCATIONS"}
)  # fmt: skip
WHOLE_KEYS = frozenset({"MIN_EVAL_TRIALS", "NUMBER_OF_OBSTACLES", "NUMBER_OF_BOT_CARS"})
NUMBER_KEYS = frozenset(
    {"ROUND_ROBIN_ADVANCE_DIST", "START_POSITION_OFFSET", "MIN_DISTANCE_BETWEEN_OBSTACLES", "LOWER_LANE_CHANGE_TIME",
     "UPPER_LANE_CHANGE_TIME", "LANE_CHANGE_DISTANCE", "MIN_DISTANCE_BETWEEN_BOT_CARS", "BOT_CAR_SPEED",
     "PENALTY_SECONDS"}
)  # fmt: skip


def _param(env: Env, key: str, variable: str, default: str | None) -> Param:
    assignment = env.get(variable)
    return Param(key, variable, assignment.value if assignment is not None else default, assignment)


def challenge_params(env: Env, race_type: str | None, first: bool) -> Params:
    """The obstacle or bot-car keys of a race type (`first`: with worker 1's defaults, which the evaluation's
    prepare-config.py shares; else none, as for workers 2 and up)."""
    params: Params = {}
    if race_type == "OBJECT_AVOIDANCE":
        for key, (variable, default) in OBSTACLE_VARIABLES.items():
            params[key] = _param(env, key, variable, default if first or key == "OBSTACLE_TYPE" else None)
        positions = env.get(OBJECT_POSITIONS_VARIABLE)
        text = "" if positions is None else positions.value.replace('"', "")
        if text != "":
            params["OBJECT_POSITIONS"] = Param("OBJECT_POSITIONS", OBJECT_POSITIONS_VARIABLE, text, positions)
            count = str(len(text.split(";")))
            params["NUMBER_OF_OBSTACLES"] = Param("NUMBER_OF_OBSTACLES", OBJECT_POSITIONS_VARIABLE, count, positions)
    if race_type == "HEAD_TO_BOT":
        for key, (variable, default) in BOT_CAR_VARIABLES.items():
            params[key] = _param(env, key, variable, default if first else None)
    return params


def _first_worker(env: Env) -> Params:
    params: Params = {}
    for key, variable, default in (
        ("WORLD_NAME", "DR_WORLD_NAME", "LGSWide"),
        ("RACE_TYPE", "DR_RACE_TYPE", "TIME_TRIAL"),
        ("REVERSE_DIR", "DR_TRAIN_REVERSE_DIRECTION", "False"),
        ("ROUND_ROBIN_ADVANCE_DIST", "DR_TRAIN_ROUND_ROBIN_ADVANCE_DIST", "0.05"),
        ("START_POSITION_OFFSET", "DR_TRAIN_START_POSITION_OFFSET", "0.00"),
        ("ENABLE_DOMAIN_RANDOMIZATION", "DR_ENABLE_DOMAIN_RANDOMIZATION", "false"),
        ("MIN_EVAL_TRIALS", "DR_TRAIN_MIN_EVAL_TRIALS", "5"),
        ("BEST_MODEL_METRIC", "DR_TRAIN_BEST_MODEL_METRIC", "progress"),
    ):
        params[key] = _param(env, key, variable, default)
    for key, variable, older, default in (  # the older names, for worker 1 only
        ("ALTERNATE_DRIVING_DIRECTION", "DR_TRAIN_ALTERNATE_DRIVING_DIRECTION", "DR_ALTERNATE_DRIVING_DIRECTION", "false"),
        ("CHANGE_START_POSITION", "DR_TRAIN_CHANGE_START_POSITION", "DR_CHANGE_START_POSITION", "true"),
    ):  # fmt: skip
        params[key] = _param(env, key, older if variable not in env and older in env else variable, default)
    return {**params, **challenge_params(env, params["RACE_TYPE"].value, first=True)}


def _next_worker(previous: Params, env: Env) -> Params:
    params = dict(previous)
    for key, (variable, default) in WORKER_VARIABLES.items():
        params[key] = _param(env, key, variable, default)
    race_type = params["RACE_TYPE"].value
    if race_type != "OBJECT_AVOIDANCE":  # prepare-config.py drops these, but keeps OBSTACLE_TYPE
        for key in (*OBSTACLE_VARIABLES, "OBJECT_POSITIONS"):
            if key != "OBSTACLE_TYPE":
                params.pop(key, None)
    else:
        params.pop("OBJECT_POSITIONS", None)
    if race_type != "HEAD_TO_BOT":  # ... and these, but keeps PENALTY_SECONDS
        for key in BOT_CAR_VARIABLES:
            if key != "PENALTY_SECONDS":
                params.pop(key, None)
    return {**params, **challenge_params(env, race_type, first=False)}


def experiment_worker_params(experiment: DrfcExperiment) -> tuple[Params, ...]:
    """One Params per worker (worker 0 is DRfC's worker 1); without multi-config all workers share worker 1's."""
    first = _first_worker(experiment.env)
    if not experiment.multi_config:
        return (first,) * experiment.num_workers
    workers = [first]
    for env in experiment.worker_envs[1:]:
        workers.append(_next_worker(workers[-1], env))
    return tuple(workers)


def worker_file_notes(experiment: DrfcExperiment) -> list[str]:
    """worker-N.env lines that set a variable prepare-config.py does not read per worker (no effect there either)."""
    ignored = [
        f"{a.name} ({a.where})"
        for file in experiment.worker_files
        for a in file.assignments
        if a.name not in PER_WORKER_VARIABLES
    ]
    if not ignored:
        return []
    return [
        f"no effect, as in DRfC (its prepare-config.py reads only the per-worker variables from worker-N.env): "
        f"{', '.join(ignored)}"
    ]


def racer_params(params: Mapping[str, Param], worker_id: int) -> dict[str, str]:
    """The worker's training_params as racer reads them (strings, DeepRacer's spelling), each value checked; a bad
    one raises DrfcFileError naming its variable and the line that set it."""
    result: dict[str, str] = {}
    for key, param in params.items():
        result[key] = _checked(param, worker_id)
    try:
        WorkerSettings.from_training_params(result, source=f"worker {worker_id}")
    except ValueError as error:
        raise DrfcFileError(_with_origin(str(error), params)) from None
    return result


def _checked(param: Param, worker_id: int) -> str:
    if param.value is None:
        raise DrfcFileError(
            f"worker {worker_id} (DRfC's worker {worker_id + 1}): {param.variable} is not set: DRfC's "
            f"prepare-config.py reads it without a default for workers 2 and up and writes null, on which the SimApp "
            f"fails; set it in run.env or worker-{worker_id + 1}.env"
        )
    text = param.value
    if param.key in FLAG_KEYS:
        if text.lower() not in {"true", "false"}:
            raise DrfcFileError(
                f"{param.describe()}: the SimApp reads True or False here (deepracer-simapp 01f5f015 "
                f"bundle/markov/utils.py str2bool)"
            )
        return "True" if text.lower() == "true" else "False"
    try:
        if param.key in WHOLE_KEYS:
            return str(int(text))
        if param.key in NUMBER_KEYS:
            return str(float(text))
    except ValueError:
        kind = "a whole number" if param.key in WHOLE_KEYS else "a number"
        raise DrfcFileError(f"{param.describe()}: not {kind}") from None
    if not text.strip():
        raise DrfcFileError(f"{param.describe()}: empty")
    return text


def _with_origin(message: str, params: Mapping[str, Param]) -> str:
    """WorkerSettings' error ("worker 1: RACE_TYPE: ...") with the line that set the key it names."""
    detail = message.split(": ", 1)[-1]
    named = [key for key in params if detail.startswith(key)]
    if not named:
        return message
    return f"{message} (from {params[max(named, key=len)].describe()})"
