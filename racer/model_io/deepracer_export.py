"""What DeepRacer's own software needs from a racer model: TensorFlow files and DRoA's import folder.

For every racer checkpoint an export copies, `model/<N>_Step-<M>.ckpt.{index,data-00000-of-00001,meta}` (a real
TensorFlow checkpoint with RL Coach's variable names, which DRoA's validator restores) and `model/model_<N>.pb` (the
frozen graph the car and DRoA run), made in a TensorFlow process of their own (tensorflow/runner.py).

`--for droa` writes the folder DeepRacer on AWS imports (its `source/docs/import/README.md`): `model/` with
`.coach_checkpoint`, `deepracer_checkpoints.json`, the TensorFlow checkpoint files and `model_<N>.pb`; at the root
`model_metadata.json`, `reward_function.py`, `training_params.yaml`, `hyperparameters.json` and the training metrics
as `metrics/training/training-<name>.json`. racer's own files (safetensors, manifests, ONNX) stay out: DRoA would
ignore them and they count against its 1 GB limit.

Any network racer trains gets its TensorFlow files: DeepRacer's three, your own (network.json) and stacked frames
(hyperparameters.json stack_size > 1, the camera placeholder taking C * N channels). `--for droa` refuses your own
network and stacked frames (`refuse_for_droa`): DeepRacer on AWS imports only its three networks, fed single frames.
"""

from __future__ import annotations

import dataclasses
import json
import re

from racer.model_io import checkpoints as ck
from racer.model_io.problems import ImportPlan
from racer.model_io.sources import StoreSource
from racer.model_io.tensorflow.errors import (
    CustomNetworkExportError,
    custom_network_export_refusal,
    stacked_frames_export_refusal,
)
from racer.shared import model_layout
from racer.shared.deepracer.model_metadata import NEURAL_NETWORKS, ContinuousActionSpace, parse_model_metadata
from racer.shared.model_layout import RACER_CHECKPOINT_SUFFIXES, CheckpointName
from racer.shared.policy.policy_config import PolicyConfig
from racer.shared.store import ObjectNotFoundError, join_key

__all__ = ["EXPORT_LAYOUTS", "droa_plan", "droa_targets", "refuse_for_droa", "tensorflow_exports"]

EXPORT_LAYOUTS = ("racer", "droa")
_TRAINING_METRICS = re.compile(r"^(?:metrics/)?(TrainingMetrics[^/]*)\.json$")


def tensorflow_exports(source: StoreSource, plan: ImportPlan, layout: str = "racer") -> dict[str, bytes]:
    """TensorFlow checkpoint files and `model_<N>.pb` for every racer checkpoint of the plan, keyed like the plan.
    `layout` droa: a checkpoint whose manifest says your own network or stacked frames is refused (the manifest's
    word, whatever the model's files say)."""
    from racer.model_io.tensorflow.convert import ExportJob, tensorflow_files  # torch and numpy, only when asked
    from racer.shared.policy.checkpoints import CheckpointStore

    checkpoints = CheckpointStore(source.store, source.prefix)
    jobs = []
    for text in plan.selection.checkpoints:
        name = CheckpointName.parse(text)  # validation accepted it
        if not ck.is_racer_checkpoint(name, plan.checkpoint_files):
            continue  # a TensorFlow checkpoint already: its files are copied as they are
        network = checkpoints.load_policy(name.name)
        if layout == "droa":
            _refuse_config_for_droa(network.config)
        jobs.append(ExportJob(network, name.name, name.number, _action_space(source, checkpoints, name.name)))
    files: dict[str, bytes] = {}
    for produced in tensorflow_files(jobs) if jobs else []:
        files.update({f"{ck.MODEL_DIR}{file_name}": data for file_name, data in produced.items()})
    return files


def _action_space(source: StoreSource, checkpoints, name: str) -> ContinuousActionSpace | None:
    """The continuous action space the checkpoint was trained with (SAC's Q networks read it): its manifest's, else
    the model's model_metadata.json."""
    metadata = checkpoints.read_info(name).model_metadata
    where = f"{name} manifest"
    if metadata is None:
        where = join_key(source.prefix, model_layout.MODEL_METADATA)
        metadata = json.loads(source.store.get_bytes(where).decode("utf-8-sig"))
    return parse_model_metadata(metadata, where).continuous_action_space


def refuse_for_droa(source: StoreSource, layout: str) -> None:
    """Before anything is copied: DeepRacer on AWS imports only its three networks, fed single frames."""
    if layout != "droa":
        return
    try:
        metadata = json.loads(source.store.get_bytes(join_key(source.prefix, model_layout.MODEL_METADATA)))
    except (ObjectNotFoundError, ValueError):
        return  # validation reports it
    network = metadata.get("neural_network") if isinstance(metadata, dict) else None
    if isinstance(network, str) and network not in NEURAL_NETWORKS:
        raise CustomNetworkExportError(custom_network_export_refusal(network))
    stack_size = _stack_size(source)
    if stack_size > 1:
        raise CustomNetworkExportError(stacked_frames_export_refusal(stack_size))


def _refuse_config_for_droa(config: PolicyConfig) -> None:
    if config.network is not None:
        raise CustomNetworkExportError(custom_network_export_refusal(config.neural_network))
    if config.stack_size > 1:
        raise CustomNetworkExportError(stacked_frames_export_refusal(config.stack_size))


def _stack_size(source: StoreSource) -> int:
    """hyperparameters.json's stack_size (1 when the file or the key is missing or unreadable: validation reports it)."""
    for key in (model_layout.HYPERPARAMETERS, "hyperparameters.json"):
        try:
            data = json.loads(source.store.get_bytes(join_key(source.prefix, key)).decode("utf-8-sig"))
        except (ObjectNotFoundError, ValueError):
            continue
        try:
            return int(float(data.get("stack_size", 1))) if isinstance(data, dict) else 1
        except (TypeError, ValueError):
            return 1
    return 1


def droa_plan(plan: ImportPlan) -> ImportPlan:
    """The plan without racer's own checkpoint files and ONNX models, and with only the training metrics."""
    keep = tuple(key for key in plan.checkpoint_files if not key.endswith(".onnx") and not _is_racer_part(key))
    optional = tuple(key for key in plan.optional_keys if _TRAINING_METRICS.match(key))
    return dataclasses.replace(plan, checkpoint_files=keep, optional_keys=optional)


def droa_targets(key: str) -> str:
    """Where DRoA's import expects a copied file: training metrics go to metrics/training/training-<name>.json."""
    match = _TRAINING_METRICS.match(key)
    return model_layout.droa_training_metrics(match.group(1)) if match else key


def _is_racer_part(key: str) -> bool:
    name = CheckpointName.of_file(key.removeprefix(ck.MODEL_DIR))
    return name is not None and key.removeprefix(f"{ck.MODEL_DIR}{name.name}") in RACER_CHECKPOINT_SUFFIXES
