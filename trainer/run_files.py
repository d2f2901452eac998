"""The run's files: read and check the custom files once (racer.trainer.preflight), then publish them into the
store for the workers, the evaluation and clones.

A new run publishes, beside its checkpoints: model_metadata.json (verbatim), network.json and preset.json when the
custom files hold them (verbatim), the hyperparameters (DeepRacer's JSON), the reward function, one
training_params YAML per worker (worker 0's always, another worker's only when it differs) and, last, `ip/done`.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path

from racer.shared.deepracer.hyperparameters import Hyperparameters, hyperparameters_to_json_bytes
from racer.shared.deepracer.model_metadata import ModelMetadata
from racer.shared.deepracer.training_params import training_params_to_yaml
from racer.shared.model_layout import ModelLayout
from racer.shared.policy.network_file import NETWORK_FILE, NetworkFile
from racer.shared.run_settings import RunOptions
from racer.shared.store import ObjectStore
from racer.shared.worker_settings import WorkerSettings
from racer.trainer.preflight import PreflightReport, preflight
from racer.trainer.preset import PRESET_FILE, Preset

log = logging.getLogger(__name__)

MODEL_METADATA_FILE = "model_metadata.json"
REWARD_FUNCTION_FILE = "reward_function.py"


@dataclass(frozen=True)
class RunFiles:
    """The custom files of one run, read and checked."""

    folder: Path
    model_metadata: ModelMetadata
    hyperparameters: Hyperparameters
    reward_function: bytes
    workers: tuple[WorkerSettings, ...]
    network: NetworkFile | None
    """network.json of the custom files when model_metadata.json names it."""
    preset: Preset | None
    """preset.json of the custom files, when there is one."""


def read_run_files(folder: Path, run: RunOptions, report: PreflightReport | None = None) -> RunFiles:
    """Preflight the custom files (a refusal raises) and log its warnings; `report`: the check `racer trainer` or
    `racer train` already ran (preflight runs once per run), so only the files are read."""
    report = report or preflight(folder, run)
    for warning in report.warnings:
        log.warning(warning)
    return RunFiles(
        folder=folder,
        model_metadata=report.model_metadata,
        hyperparameters=report.hyperparameters,
        reward_function=(folder / REWARD_FUNCTION_FILE).read_bytes(),
        workers=tuple(report.workers),
        network=report.network,
        preset=report.preset,
    )


def publish_run_files(store: ObjectStore, layout: ModelLayout, model_prefix: str, files: RunFiles) -> None:
    """Write the run's files into the store, `ip/done` last."""
    store.put_bytes(layout.model_metadata, (files.folder / MODEL_METADATA_FILE).read_bytes())
    if files.network is not None:  # beside model_metadata.json, verbatim: evaluation and clones read it
        store.put_bytes(layout.network, (files.folder / NETWORK_FILE).read_bytes())
    if files.preset is not None:  # beside the hyperparameters, verbatim
        store.put_bytes(layout.preset, (files.folder / PRESET_FILE).read_bytes())
    store.put_bytes(
        layout.hyperparameters,
        hyperparameters_to_json_bytes(files.hyperparameters, files.model_metadata.training_algorithm),
    )
    store.put_bytes(layout.reward_function, files.reward_function)
    params = [w.to_training_params(model_prefix, len(files.workers)) for w in files.workers]
    for worker_id, worker_params in enumerate(params):
        if worker_id == 0 or worker_params != params[0]:
            store.put_bytes(layout.training_params(worker_id), training_params_to_yaml(worker_params).encode())
    store.put_bytes(layout.ip_done, b"done")
