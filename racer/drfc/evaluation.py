"""A DRfC experiment as a `racer evaluate` run: DR_EVAL_* and the race settings, as DRfC's evaluation reads them.

deepracer-for-cloud 2eb1a1f1 `scripts/evaluation/prepare-config.py` reads no worker-N.env, and its defaults are:
NUMBER_OF_TRIALS 5, IS_CONTINUOUS True, NUMBER_OF_RESETS 0, OFF_TRACK_PENALTY 5.0, EVAL_CHECKPOINT last, and the
collision penalty from DR_COLLISION_PENALTY (5.0) -- not from DR_EVAL_COLLISION_PENALTY, which the template sets and
nothing reads; racer follows that and says so when the two differ. HEAD_TO_MODEL adds DR_EVAL_OPP_S3_MODEL_PREFIX as
a second car. The SimApp (deepracer-simapp 01f5f015 `bundle/markov/evaluation_worker.py`) takes EVAL_CHECKPOINT
"best" in any case, else the last checkpoint, and IS_CONTINUOUS and REVERSE_DIR as True or False.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from racer.drfc.experiment import DrfcExperiment, Env, read_experiment
from racer.drfc.notices import variable_notes
from racer.drfc.shell_env import DrfcFileError
from racer.drfc.simapp_version import simapp_generation
from racer.drfc.training import DEFAULT_MODEL_PREFIX, TRUE_WORDS
from racer.drfc.training_params import Param, challenge_params, racer_params
from racer.shared.sim.objects.challenge import MULTI_CAR_RACE_TYPES

__all__ = ["DrfcEvaluation", "read_evaluation"]

HEAD_TO_MODEL = "HEAD_TO_MODEL"


@dataclass(frozen=True)
class DrfcEvaluation:
    """`racer evaluate`'s options, as the experiment sets them."""

    experiment: DrfcExperiment
    model_prefix: str
    checkpoint: str
    track: str
    reverse: bool
    trials: int
    continuous: bool
    resets: int
    off_track_penalty_s: float
    collision_penalty_s: float
    video: bool
    race_type: str | None
    """None: HEAD_TO_MODEL, a race of `opponents`."""
    race_params: tuple[tuple[str, str], ...]
    """The obstacle / bot-car keys and RESET_BEHIND_DIST (training_params names), RACE_TYPE left out."""
    opponents: tuple[str, ...]
    generation: str | None
    """The generation DR_SIMAPP_VERSION stands for; None: racer's default."""
    notes: tuple[str, ...]


def read_evaluation(path: Path, drfc_dir: Path | None = None) -> DrfcEvaluation:
    """Read the experiment (run.env and system.env) and map its evaluation; raises DrfcFileError (file, line).
    `drfc_dir`: $DR_DIR (experiment.read_experiment)."""
    experiment = read_experiment(path, training=False, drfc_dir=drfc_dir)
    env = experiment.env
    notes = [*experiment.notes, *variable_notes(experiment, "evaluate")]
    generation, generation_notes = simapp_generation(env.get("DR_SIMAPP_VERSION"))
    notes += generation_notes

    def param(key: str, variable: str, default: str) -> Param:
        assignment = env.get(variable)
        return Param(key, variable, assignment.value if assignment is not None else default, assignment)

    race = param("RACE_TYPE", "DR_RACE_TYPE", "TIME_TRIAL")
    world = param("WORLD_NAME", "DR_WORLD_NAME", "LGSWide")
    opponents: tuple[str, ...] = ()
    race_type: str | None = race.value
    if race.value == HEAD_TO_MODEL:
        opponent = param("", "DR_EVAL_OPP_S3_MODEL_PREFIX", DEFAULT_MODEL_PREFIX)
        opponents, race_type = (str(opponent.value).strip("/"),), None
    elif race.value in MULTI_CAR_RACE_TYPES:
        raise DrfcFileError(
            f"{race.describe()}: DRfC evaluates TIME_TRIAL, OBJECT_AVOIDANCE, HEAD_TO_BOT or HEAD_TO_MODEL"
        )
    challenge = {
        "WORLD_NAME": world,
        "RACE_TYPE": Param("RACE_TYPE", race.variable, race_type or "TIME_TRIAL", race.origin),
        "REVERSE_DIR": param("REVERSE_DIR", "DR_EVAL_REVERSE_DIRECTION", "False"),
        **challenge_params(env, race_type, first=True),
    }
    checked = racer_params(challenge, 0)  # the same checks as a training worker's, naming the variable and line
    resets = _whole(param("NUMBER_OF_RESETS", "DR_EVAL_MAX_RESETS", "0"), 0)
    if resets == 1:
        raise DrfcFileError(f"{_where(env, 'DR_EVAL_MAX_RESETS')}: 1: the SimApp takes 0, or 2 and more")
    collision = param("COLLISION_PENALTY", "DR_COLLISION_PENALTY", "5.0")
    notes += _collision_note(env, collision)
    reset_behind = _number(param("RESET_BEHIND_DIST", "DR_EVAL_RESET_BEHIND_DIST", "1.0"))
    race_params = tuple((k, v) for k, v in checked.items() if k not in {"WORLD_NAME", "RACE_TYPE", "REVERSE_DIR"})
    return DrfcEvaluation(
        experiment=experiment,
        model_prefix=_text(param("", "DR_LOCAL_S3_MODEL_PREFIX", DEFAULT_MODEL_PREFIX)).strip("/"),
        checkpoint="best" if str(param("", "DR_EVAL_CHECKPOINT", "last").value).lower() == "best" else "last",
        track=checked["WORLD_NAME"],
        reverse=checked["REVERSE_DIR"] == "True",
        trials=_whole(param("NUMBER_OF_TRIALS", "DR_EVAL_NUMBER_OF_TRIALS", "5"), 1),
        continuous=_flag(param("IS_CONTINUOUS", "DR_EVAL_IS_CONTINUOUS", "True")),
        resets=resets,
        off_track_penalty_s=_number(param("OFF_TRACK_PENALTY", "DR_EVAL_OFF_TRACK_PENALTY", "5.0")),
        collision_penalty_s=_number(collision),
        video=str(param("", "DR_EVAL_SAVE_MP4", "False").value).lower() in TRUE_WORDS,
        race_type=race_type,
        race_params=(*race_params, ("RESET_BEHIND_DIST", str(reset_behind))),
        opponents=opponents,
        generation=generation,
        notes=tuple(notes),
    )


def _where(env: Env, variable: str) -> str:
    assignment = env.get(variable)
    return f"{assignment.where}: {variable}" if assignment is not None else variable


def _text(param: Param) -> str:
    if not str(param.value).strip():
        raise DrfcFileError(f"{param.describe()}: empty")
    return str(param.value)


def _whole(param: Param, minimum: int) -> int:
    try:
        number = int(str(param.value))
    except ValueError:
        number = minimum - 1
    if number < minimum:
        raise DrfcFileError(f"{param.describe()}: not a whole number of {minimum} or more")
    return number


def _number(param: Param) -> float:
    try:
        number = float(str(param.value))
    except ValueError:
        number = -1.0
    if number < 0:
        raise DrfcFileError(f"{param.describe()}: not a number of 0 or more")
    return number


def _flag(param: Param) -> bool:
    text = str(param.value).lower()
    if text not in {"true", "false"}:
        raise DrfcFileError(f"{param.describe()}: the SimApp reads True or False here")
    return text == "true"


def _collision_note(env: Env, collision: Param) -> list[str]:
    ignored = env.get("DR_EVAL_COLLISION_PENALTY")
    if ignored is None:
        return []
    try:
        same = float(ignored.value) == float(str(collision.value))
    except ValueError:
        same = False
    if same:
        return []
    return [
        f"{ignored.where}: DR_EVAL_COLLISION_PENALTY={ignored.value} has no effect: DRfC's evaluation reads "
        f"DR_COLLISION_PENALTY ({collision.value} here), and so does racer; set that, or give --collision-penalty"
    ]
