"""What a rollout worker reads from the store before it can play: the run's files, validated.

The trainer uploads them (model/model_metadata.json, ip/hyperparameters.json, reward_function.py,
training_params[_<i>].yaml); every worker reads the same copies, so all of them play the same model.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

from racer.shared.deepracer.hyperparameters import Hyperparameters, parse_hyperparameters
from racer.shared.deepracer.model_metadata import ModelMetadata, parse_model_metadata
from racer.shared.deepracer.training_params import parse_training_params
from racer.shared.model_layout import ModelLayout
from racer.shared.run_settings import JobSettings, env_config
from racer.shared.sim.config import EnvConfig
from racer.shared.sim.objects.challenge import param_text
from racer.shared.store import ObjectNotFoundError, ObjectStore
from racer.shared.worker_settings import WorkerSettings


@dataclass(frozen=True)
class WorkerFiles:
    """The run's files as one rollout worker uses them: the trainer's uploads and this worker's settings."""

    layout: ModelLayout
    model_metadata: ModelMetadata
    hyperparameters: Hyperparameters
    reward_function_path: Path
    """A local copy of the run's reward_function.py (the env imports it once; module state persists)."""
    worker: WorkerSettings


def read_training_params(store: ObjectStore, layout: ModelLayout, worker_id: int) -> tuple[dict[str, str], str]:
    """Worker i's training_params_<i>.yaml, or the shared training_params.yaml when the workers do not differ."""
    for key in (layout.training_params(worker_id), layout.training_params(0)):
        try:
            text = store.get_bytes(key).decode("utf-8")
        except ObjectNotFoundError:
            continue
        params = parse_training_params(text, source=f"{store.describe()}/{key}")
        return {name: param_text(value) for name, value in params.values.items()}, key
    raise ObjectNotFoundError(store.describe(), layout.training_params(0))


def load_worker_files(
    store: ObjectStore,
    model_prefix: str,
    worker_id: int,
    workdir: Path,
    world_override: str | None = None,
    track_override: str | None = None,
) -> WorkerFiles:
    layout = ModelLayout(model_prefix)
    metadata_source = f"{store.describe()}/{layout.model_metadata}"
    try:
        metadata_json = json.loads(store.get_bytes(layout.model_metadata))
    except json.JSONDecodeError as error:
        raise ValueError(f"{metadata_source}: not valid JSON: {error}") from error
    metadata = parse_model_metadata(metadata_json, source=metadata_source)
    hyper_source = f"{store.describe()}/{layout.hyperparameters}"
    try:
        hyper_json = json.loads(store.get_bytes(layout.hyperparameters))
    except json.JSONDecodeError as error:
        raise ValueError(f"{hyper_source}: not valid JSON: {error}") from error
    hyperparameters, _unknown = parse_hyperparameters(hyper_json, source=hyper_source)
    workdir.mkdir(parents=True, exist_ok=True)
    reward_path = workdir / "reward_function.py"
    reward_path.write_bytes(store.get_bytes(layout.reward_function))
    params, params_key = read_training_params(store, layout, worker_id)
    worker = WorkerSettings.from_training_params(params, source=f"{store.describe()}/{params_key}")
    worker = worker.replace(world=world_override, track=track_override)
    return WorkerFiles(
        layout=layout,
        model_metadata=metadata,
        hyperparameters=hyperparameters,
        reward_function_path=reward_path,
        worker=worker,
    )


def training_env_config(run: WorkerFiles) -> EnvConfig:
    """The env of a training worker: its training_params (DeepRacer's keys) applied to DeepRacer's defaults, through
    the run-settings builder the evaluation worker uses too (racer.shared.run_settings.env_config)."""
    return env_config(
        run.worker, JobSettings(model_metadata=run.model_metadata, reward_function_path=run.reward_function_path)
    )
