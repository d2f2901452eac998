"""A DRfC experiment as a racer training run: the model, the workers and their settings, the clone, the custom files.

Per-worker settings take racer's own path: they become the `"workers"` list of a workers.json (racer's form of
worker-N.env, racer.shared.run_settings.load_worker_settings) in a copy of the custom files, which `racer train`
then trains from. The experiment's custom_files/ may hold a workers.json of its own (racer's extension: RACER_* keys,
say); it applies over the env files, as it applies over the options in every racer run.

Sources (deepracer-for-cloud 2eb1a1f1): the model prefix and custom-file keys from `scripts/training/prepare-config.py`
and `scripts/training/start.sh`; the clone from `docker/docker-compose-training.yml` (PRETRAINED,
PRETRAINED_S3_PREFIX, PRETRAINED_CHECKPOINT), read by deepracer-simapp 01f5f015 `docker/files/rl-coach/start.py`
(str2bool: yes, true, t, 1) and `bundle/markov/training_worker.py` ("best", any case, else the last checkpoint).
"""

from __future__ import annotations

import json
import shutil
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from racer.drfc.experiment import DrfcExperiment, read_experiment
from racer.drfc.notices import variable_notes
from racer.drfc.shell_env import Assignment, DrfcFileError
from racer.drfc.simapp_version import simapp_generation
from racer.drfc.training_params import experiment_worker_params, racer_params, worker_file_notes
from racer.shared.sim.objects.challenge import CHALLENGE_KEYS, param_text
from racer.shared.worker_settings import WorkerSettings

__all__ = ["CUSTOM_FILE_KEYS", "DrfcTraining", "read_training", "run_worker_params", "write_custom_files"]

DEFAULT_MODEL_PREFIX = "rl-deepracer-sagemaker"
"""prepare-config.py's default for DR_LOCAL_S3_MODEL_PREFIX."""
DEFAULT_CUSTOM_FILES_PREFIX = "custom_files"
CUSTOM_FILE_KEYS: dict[str, str] = {
    "reward_function.py": "DR_LOCAL_S3_REWARD_KEY",
    "model_metadata.json": "DR_LOCAL_S3_MODEL_METADATA_KEY",
    "hyperparameters.json": "DR_LOCAL_S3_HYPERPARAMETERS_KEY",
}
"""racer's custom file -> the variable that names DRfC's key for it."""
WORKERS_FILE = "workers.json"
TRUE_WORDS = ("yes", "true", "t", "1")
"""What the SimApp's rl-coach start.py takes as true for PRETRAINED."""


@dataclass(frozen=True)
class DrfcTraining:
    experiment: DrfcExperiment
    model_prefix: str
    worker_params: tuple[dict[str, str], ...]
    """Each worker's training_params (worker 0 first), checked."""
    custom_file_sources: Mapping[str, Path]
    """racer's file name -> the experiment's file."""
    pretrained_prefix: str | None
    pretrained_checkpoint: str
    viewer_port: int | None
    """DR_WEBVIEWER_PORT; None when unset."""
    generation: str | None
    """The generation DR_SIMAPP_VERSION stands for; None: racer's default."""
    notes: tuple[str, ...]

    @property
    def num_workers(self) -> int:
        return len(self.worker_params)


def read_training(path: Path, num_workers: int | None = None, drfc_dir: Path | None = None) -> DrfcTraining:
    """Read the whole experiment and map it; raises DrfcFileError (file and line) before anything starts.
    `drfc_dir`: $DR_DIR (experiment.read_experiment)."""
    experiment = read_experiment(path, num_workers, drfc_dir=drfc_dir)
    env = experiment.env
    worker_params = tuple(
        racer_params(params, worker_id) for worker_id, params in enumerate(experiment_worker_params(experiment))
    )
    notes = [*experiment.notes, *worker_file_notes(experiment), *variable_notes(experiment, "train")]
    generation, generation_notes = simapp_generation(env.get("DR_SIMAPP_VERSION"))
    notes += generation_notes
    pretrained = env.get("DR_LOCAL_S3_PRETRAINED")
    pretrained_prefix = None
    checkpoint = "last"
    if pretrained is not None and pretrained.value.lower() in TRUE_WORDS:
        prefix = env.get("DR_LOCAL_S3_PRETRAINED_PREFIX")
        if prefix is None or not prefix.value.strip("/"):
            raise DrfcFileError(
                f"{pretrained.where}: DR_LOCAL_S3_PRETRAINED is true but DR_LOCAL_S3_PRETRAINED_PREFIX is not set"
            )
        pretrained_prefix = prefix.value.strip("/")
        chosen = env.get("DR_LOCAL_S3_PRETRAINED_CHECKPOINT")
        if chosen is not None and chosen.value.lower() == "best":
            checkpoint = "best"
        elif chosen is not None and chosen.value.lower() not in {"last", ""}:
            notes.append(
                f"{chosen.where}: DR_LOCAL_S3_PRETRAINED_CHECKPOINT={chosen.value}: the SimApp clones the last "
                f"checkpoint for anything but 'best', and so does racer"
            )
    return DrfcTraining(
        experiment=experiment,
        model_prefix=_model_prefix(env.get("DR_LOCAL_S3_MODEL_PREFIX")),
        worker_params=worker_params,
        custom_file_sources=_custom_file_sources(experiment),
        pretrained_prefix=pretrained_prefix,
        pretrained_checkpoint=checkpoint,
        viewer_port=_viewer_port(env.get("DR_WEBVIEWER_PORT")),
        generation=generation,
        notes=tuple(notes),
    )


def _model_prefix(assignment: Assignment | None) -> str:
    if assignment is None:
        return DEFAULT_MODEL_PREFIX
    prefix = assignment.value.strip("/")
    if not prefix:
        raise DrfcFileError(f"{assignment.where}: DR_LOCAL_S3_MODEL_PREFIX is empty")
    return prefix


def _viewer_port(assignment: Assignment | None) -> int | None:
    if assignment is None or not assignment.value:
        return None
    if not assignment.value.isdigit() or not 1 <= int(assignment.value) <= 65535:
        raise DrfcFileError(f"{assignment.where}: DR_WEBVIEWER_PORT={assignment.value!r} is not a port number")
    return int(assignment.value)


def _custom_file_sources(experiment: DrfcExperiment) -> dict[str, Path]:
    """Where each custom file is: its DRfC key, relative to DR_LOCAL_S3_CUSTOM_FILES_PREFIX, under custom_files/."""
    env = experiment.env
    prefix_assignment = env.get("DR_LOCAL_S3_CUSTOM_FILES_PREFIX")
    prefix = _key_parts(prefix_assignment.value if prefix_assignment else DEFAULT_CUSTOM_FILES_PREFIX)
    sources = {}
    for name, variable in CUSTOM_FILE_KEYS.items():
        assignment = env.get(variable)
        key = _key_parts(assignment.value if assignment else "/".join((*prefix, name)))
        where = f"{assignment.where}: {variable}={assignment.value}" if assignment else f"{variable} (not set)"
        if key[: len(prefix)] != prefix or len(key) == len(prefix) or ".." in key:
            raise DrfcFileError(
                f"{where}: not a file below DR_LOCAL_S3_CUSTOM_FILES_PREFIX={'/'.join(prefix)}, where "
                f"dr-upload-custom-files puts the experiment's custom_files/; racer reads the {name} from there"
            )
        path = experiment.custom_files.joinpath(*key[len(prefix) :])
        if not path.is_file():
            raise DrfcFileError(f"{where}: no {path} (the {name} of the experiment)")
        sources[name] = path
    return sources


def _key_parts(key: str) -> tuple[str, ...]:
    return tuple(part for part in key.split("/") if part not in ("", "."))


def run_worker_params(
    training: DrfcTraining,
    custom_files: Path,
    overrides: Sequence[Mapping[str, str]] = (),
    challenge_replaced: bool = False,
) -> list[dict[str, str]]:
    """Each worker's training_params for racer's workers.json: the env files', then `overrides` (what the command
    line sets, per worker), then a workers.json of `custom_files`; each checked as a worker reads it.
    `challenge_replaced`: the command line chose the race type, so the env files' race keys are dropped first."""
    path = custom_files / WORKERS_FILE
    shared, per_worker = _own_workers_file(path)
    workers = []
    for worker_id, params in enumerate(training.worker_params):
        settings = {k: v for k, v in params.items() if not (challenge_replaced and k in CHALLENGE_KEYS)}
        if worker_id < len(overrides):
            settings.update(overrides[worker_id])
        settings.update(shared)
        if worker_id < len(per_worker):
            settings.update(per_worker[worker_id])
        source = f"worker {worker_id}, from the DRfC files, the command line" + (
            f" and {path}" if path.is_file() else ""
        )
        try:
            WorkerSettings.from_training_params(settings, source)
        except ValueError as error:
            raise DrfcFileError(str(error)) from None
        workers.append(settings)
    return workers


def write_custom_files(
    training: DrfcTraining, into: Path, workers: Sequence[Mapping[str, str]], source: Path | None = None
) -> Path:
    """Fill the empty folder `into` with the run's custom files: the experiment's files under racer's names (or
    every file of `source`, an explicit --custom-files folder, as it is) and a workers.json of `workers`."""
    folder = source if source is not None else training.experiment.custom_files
    for entry in sorted(folder.iterdir()) if folder.is_dir() else ():
        if entry.is_file() and entry.name != WORKERS_FILE:
            shutil.copyfile(entry, into / entry.name)
    if source is None:
        for name, path in training.custom_file_sources.items():
            shutil.copyfile(path, into / name)
    (into / WORKERS_FILE).write_text(json.dumps({"workers": list(workers)}, indent=2) + "\n")
    return into


def _own_workers_file(path: Path) -> tuple[dict[str, str], list[dict[str, str]]]:
    """A workers.json in the custom files: (keys for every worker, per-worker keys), values as text."""
    if not path.is_file():
        return {}, []
    try:
        data = json.loads(path.read_text())
    except json.JSONDecodeError as error:
        raise DrfcFileError(f"{path}: line {error.lineno} column {error.colno}: {error.msg}") from None
    if not isinstance(data, dict) or not isinstance(data.get("workers", []), list):
        raise DrfcFileError(f"{path}: expected an object of training_params keys, with an optional 'workers' list")
    per_worker = data.pop("workers", [])
    if not all(isinstance(item, dict) for item in per_worker):
        raise DrfcFileError(f"{path}: workers: expected one object per worker")
    return (
        {k: param_text(v) for k, v in data.items()},
        [{k: param_text(v) for k, v in item.items()} for item in per_worker],
    )
