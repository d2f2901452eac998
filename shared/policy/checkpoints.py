"""A training run's checkpoints in DeepRacer's `model/` folder, through any ObjectStore (S3/MinIO or a directory).

The keys are racer.shared.model_layout's. One checkpoint `<N>_Step-<M>.ckpt` (N from 0, M = env steps consumed) is:

    model/<N>_Step-<M>.ckpt.weights.safetensors     network weights (state_dict names, float32, no pickle)
    model/<N>_Step-<M>.ckpt.optimizer.safetensors   optimiser tensors (racer.shared.policy.optimizer_files)
    model/<N>_Step-<M>.ckpt.optimizer.json          optimiser scalars
    model/<N>_Step-<M>.ckpt.json                    manifest (racer.shared.policy.manifest), written last
    model/model_<N>.onnx                            inference model (racer.shared.policy.onnx_export)

Publishing is atomic for readers: `.lock` goes up, every file of checkpoint N is written (the manifest last), then
`.coach_checkpoint` moves to N, then `.lock` goes away. A reader following the pointer therefore never meets a
missing or half-written file, and `load()` verifies sizes and sha256 anyway. Retention, after the pointer moved:
keep the 4 newest checkpoints plus the best one named in deepracer_checkpoints.json; delete the others with their
`model_<N>.onnx` (DeepRacer's NUM_MODELS_TO_KEEP = 4, best re-queued).

    checkpoints = CheckpointStore(store, model_prefix)
    name = checkpoints.save(N, M, network, optimizer, model_metadata, hyperparameters)   -> "N_Step-M.ckpt"
    checkpoints.latest_name(), .names(), .select("best" | "last" | name)
    number, env_steps = checkpoints.restore(name, network, optimizer=None)
    checkpoints.load(name), .load_policy(name), .load_inference_policy(name); .checkpoint_files() + .publish(): save
    checkpoints.record_evaluation(name, avg_eval_metric, time_stamp)    DeepRacer's best/last rule

Importing this module imports no torch: what the rollout and evaluation workers do (the pointer, manifests,
`load_inference_policy`: the ONNX model and a continuous policy's log-std through safetensors' numpy API, best/last)
runs without it, so their image has none. The methods that build or fill a torch network (`load`, `restore`,
`load_policy`, `save`) import the torch side, racer.shared.policy.checkpoint_tensors, when called.
"""

from __future__ import annotations

import json
import time
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from safetensors.numpy import load as load_numpy_tensors

from racer.shared import model_layout
from racer.shared.deepracer.hyperparameters import (
    Hyperparameters,
    hyperparameters_to_json_bytes,
    resolved_hyperparameters,
)
from racer.shared.deepracer.model_metadata import ModelMetadata, model_metadata_to_dict
from racer.shared.model_layout import (
    MANIFEST_SUFFIX,
    OPTIMIZER_SCALARS_SUFFIX,
    OPTIMIZER_TENSORS_SUFFIX,
    WEIGHTS_SUFFIX,
    CheckpointName,
    ModelLayout,
    checkpoint_name,
)
from racer.shared.policy.action_selection import LOG_STD_MAX, LOG_STD_MIN
from racer.shared.policy.best_and_last import (
    BestAndLast,
    CheckpointRecord,
    after_evaluation,
    best_and_last_to_bytes,
    read_best_and_last,
)
from racer.shared.policy.manifest import CheckpointError, CheckpointInfo, package_versions, sha256_hex
from racer.shared.store import ObjectNotFoundError, ObjectStore

if TYPE_CHECKING:
    import torch

    from racer.shared.policy.factory import PolicyNetwork

__all__ = [
    "NUM_CHECKPOINTS_TO_KEEP",
    "BestAndLast",
    "CheckpointError",
    "CheckpointFiles",
    "CheckpointInfo",
    "CheckpointRecord",
    "CheckpointStore",
    "LoadedCheckpoint",
]

NUM_CHECKPOINTS_TO_KEEP = 4


@dataclass(frozen=True)
class LoadedCheckpoint:
    info: CheckpointInfo
    network_state: dict[str, torch.Tensor]
    optimizer_state: dict | None
    """In torch's `Optimizer.state_dict()` form, for `load_optimizer_state`; None if the checkpoint has none."""


@dataclass(frozen=True)
class CheckpointFiles:
    """One checkpoint's files before they are published: file name -> bytes, and its manifest."""

    name: str
    files: dict[str, bytes]
    manifest: bytes


class CheckpointStore:
    """DeepRacer's `model/` folder of one training run, in an ObjectStore under `model_prefix`."""

    def __init__(self, store: ObjectStore, model_prefix: str, keep: int = NUM_CHECKPOINTS_TO_KEEP):
        self.store = store
        self.layout = ModelLayout(model_prefix)
        self.keep = keep

    def _file(self, name: str, suffix: str) -> str:
        return self.layout.checkpoint_file(name, suffix)

    def _nothing_to_load(self) -> CheckpointError:
        return CheckpointError(f"{self.store.describe()}: no {self.layout.coach_checkpoint!r}; nothing to load")

    # -- reading -----------------------------------------------------------------------------------------------------

    def latest_name(self) -> str | None:
        """The checkpoint `.coach_checkpoint` names, or None before checkpoint 0 is published."""
        try:
            text = self.store.get_bytes(self.layout.coach_checkpoint).decode("utf-8").strip()
        except ObjectNotFoundError:
            return None
        CheckpointName.parse(text)
        return text

    def is_locked(self) -> bool:
        """True while a checkpoint upload is in progress (DeepRacer's rollout workers wait for it to clear)."""
        return self.store.exists(self.layout.lock)

    def names(self) -> list[str]:
        """Complete checkpoints (manifest present), oldest first."""
        found = []
        for key in self.store.list_keys(self.layout.model_dir):
            file_name = key.rsplit("/", 1)[-1]
            name = CheckpointName.find(file_name.removesuffix(MANIFEST_SUFFIX))
            if name is not None and file_name == name.name + MANIFEST_SUFFIX:
                found.append(name)
        return [name.name for name in sorted(found)]

    def read_info(self, name: str) -> CheckpointInfo:
        try:
            data = json.loads(self.store.get_bytes(self._file(name, MANIFEST_SUFFIX)))
        except ObjectNotFoundError:
            if self.store.exists(self._file(name, ".index")):
                raise CheckpointError(
                    f"{self.store.describe()}: {self.layout.key(model_layout.MODEL_DIR, name)} is a TensorFlow "
                    f"checkpoint (AWS console or DeepRacer-for-Cloud): its files are kept, but racer evaluates and "
                    f"clones only the PyTorch checkpoints it trains itself"
                ) from None
            raise CheckpointError(
                f"{self.store.describe()}: checkpoint {name} has no manifest "
                f"{self._file(name, MANIFEST_SUFFIX)!r} (not saved, or deleted by retention)"
            ) from None
        return CheckpointInfo.from_dict(data)

    def _read_verified(self, info: CheckpointInfo, file_name: str) -> bytes:
        key = self.layout.key(model_layout.MODEL_DIR, file_name)
        try:
            data = self.store.get_bytes(key)
        except ObjectNotFoundError:
            raise CheckpointError(f"{self.store.describe()}: {key!r} of checkpoint {info.name} is missing") from None
        expected = info.files[file_name]
        if len(data) != expected["size_bytes"] or sha256_hex(data) != expected["sha256"]:
            raise CheckpointError(f"{self.store.describe()}: {key!r} does not match its manifest (corrupt or replaced)")
        return data

    def load(self, name: str | None = None) -> LoadedCheckpoint:
        """Weights, optimiser state and manifest of `name` (default: the pointer's checkpoint)."""
        from racer.shared.policy.checkpoint_tensors import build_network, optimizer_state_from_files, tensors_from_bytes

        name = name or self.latest_name()
        if name is None:
            raise self._nothing_to_load()
        info = self.read_info(name)
        network_state = tensors_from_bytes(self._read_verified(info, name + WEIGHTS_SUFFIX))
        optimizer_state = None
        if name + OPTIMIZER_TENSORS_SUFFIX in info.files:
            tensors = tensors_from_bytes(self._read_verified(info, name + OPTIMIZER_TENSORS_SUFFIX))
            scalars = json.loads(self._read_verified(info, name + OPTIMIZER_SCALARS_SUFFIX))
            network = build_network(info.policy_config)
            optimizer_state = optimizer_state_from_files(tensors, scalars, network)
        return LoadedCheckpoint(info=info, network_state=network_state, optimizer_state=optimizer_state)

    def restore(
        self, name: str, network: PolicyNetwork, optimizer: torch.optim.Optimizer | None = None
    ) -> tuple[int, int]:
        """Load a checkpoint into an existing network (and optimiser, if given). Returns (number, env_steps).

        The network must have the checkpoint's structure (same PolicyConfig); without an optimiser only the weights
        are restored (e.g. cloning a pretrained model).
        """
        from racer.shared.policy.checkpoint_tensors import load_optimizer_state, tensors_from_bytes

        loaded = self.load(name) if optimizer is not None else None
        info = loaded.info if loaded is not None else self.read_info(name)
        if info.policy_config != network.config:
            raise CheckpointError(
                f"checkpoint {name} was saved from a different network: {info.policy_config} vs {network.config}"
            )
        if loaded is not None:
            network.load_state_dict(loaded.network_state)
            if loaded.optimizer_state is None:
                raise CheckpointError(f"checkpoint {name} has no optimiser state to restore")
            load_optimizer_state(optimizer, network, loaded.optimizer_state)
        else:
            network.load_state_dict(tensors_from_bytes(self._read_verified(info, name + WEIGHTS_SUFFIX)))
        return info.number, info.env_steps

    def select(self, which: str) -> str:
        """`best` (deepracer_checkpoints.json's best, else the pointer), `last` (the pointer) or a checkpoint name."""
        if which == "last" or which == "best":
            best_and_last = self.read_best_and_last() if which == "best" else None
            if best_and_last is not None and best_and_last.best is not None and best_and_last.best.name in self.names():
                return best_and_last.best.name
            name = self.latest_name()
            if name is None:
                raise CheckpointError(
                    f"{self.store.describe()}: {self.layout.coach_checkpoint!r} is missing; no checkpoint"
                )
            return name
        CheckpointName.parse(which)
        if which not in self.names():
            raise CheckpointError(
                f"{self.store.describe()}: no complete checkpoint {which} under {self.layout.model_dir!r}; "
                f"have {', '.join(self.names()) or 'none'}"
            )
        return which

    def load_policy(self, name: str | None = None) -> PolicyNetwork:
        """The network of a checkpoint, ready to act (eval mode). Reads the weights only, not the optimiser."""
        from racer.shared.policy.checkpoint_tensors import build_network, tensors_from_bytes

        name = name or self.latest_name()
        if name is None:
            raise self._nothing_to_load()
        info = self.read_info(name)
        network = build_network(info.policy_config)
        network.load_state_dict(tensors_from_bytes(self._read_verified(info, name + WEIGHTS_SUFFIX)))
        return network.eval()

    def load_inference_policy(self, name: str | None = None):
        """The checkpoint's exported ONNX model run with ONNX Runtime: what the rollout and evaluation workers act with.

        Same actions and log-probabilities as `load_policy(name).act` (see racer.shared.policy.onnx_policy), and
        cheaper per observation, because single-frame inference is mostly framework overhead. No torch network is
        built, and torch is not imported: workers load a policy every iteration, so this stays cheap, and their image
        has no torch (the log-std is read with safetensors' numpy API).
        """
        from racer.shared.policy.onnx_policy import OnnxPolicy, SacOnnxPolicy

        name = name or self.latest_name()
        if name is None:
            raise self._nothing_to_load()
        info = self.read_info(name)
        onnx_file = model_layout.inference_model(info.number, "onnx").removeprefix(model_layout.MODEL_DIR + "/")
        if info.policy_config.training_algorithm == "sac":  # state-dependent std: the graph outputs it
            return SacOnnxPolicy(self._read_verified(info, onnx_file), info.policy_config)
        log_std = None
        if info.policy_config.is_continuous:  # the Gaussian's state-independent log-std is a weight, not in the graph
            weights = load_numpy_tensors(self._read_verified(info, name + WEIGHTS_SUFFIX))
            log_std = np.clip(weights["log_std"], LOG_STD_MIN, LOG_STD_MAX)
        return OnnxPolicy(self._read_verified(info, onnx_file), info.policy_config, log_std)

    def read_best_and_last(self) -> BestAndLast | None:
        try:
            data = self.store.get_bytes(self.layout.deepracer_checkpoints)
        except ObjectNotFoundError:
            return None
        best_and_last = read_best_and_last(data)
        if best_and_last is None:
            raise CheckpointError(f"{self.layout.deepracer_checkpoints!r} is not a JSON object")
        return best_and_last

    # -- writing -----------------------------------------------------------------------------------------------------

    def save(
        self,
        number: int,
        env_steps: int,
        network: PolicyNetwork,
        optimizer: torch.optim.Optimizer | None = None,
        model_metadata: ModelMetadata | None = None,
        hyperparameters: Hyperparameters | None = None,
        extra: Mapping | None = None,
    ) -> str:
        """Publish checkpoint `<number>_Step-<env_steps>.ckpt`, then retention; returns its name. The manifest holds
        `model_metadata` and `hyperparameters` (DeepRacer's dicts): a checkpoint says what produced it."""
        files = self.checkpoint_files(number, env_steps, network, optimizer, model_metadata, hyperparameters, extra)
        self.publish(files)
        self.apply_retention()
        return files.name

    def checkpoint_files(
        self,
        number: int,
        env_steps: int,
        network: PolicyNetwork,
        optimizer: torch.optim.Optimizer | None = None,
        model_metadata: ModelMetadata | None = None,
        hyperparameters: Hyperparameters | None = None,
        extra: Mapping | None = None,
        onnx: bytes | None = None,
    ) -> CheckpointFiles:
        """Every file of the checkpoint, in memory (`onnx`: the network's export when the caller made it already)."""
        from racer.shared.policy.checkpoint_tensors import export_onnx, optimizer_state_to_files, tensors_to_bytes

        name = checkpoint_name(number, env_steps)
        files: dict[str, bytes] = {name + WEIGHTS_SUFFIX: tensors_to_bytes(network.state_dict())}
        if optimizer is not None:
            tensors, scalars = optimizer_state_to_files(optimizer, network)
            files[name + OPTIMIZER_TENSORS_SUFFIX] = tensors_to_bytes(tensors)
            files[name + OPTIMIZER_SCALARS_SUFFIX] = json.dumps(scalars, indent=1, sort_keys=True).encode()
        onnx_file = model_layout.inference_model(number, "onnx").removeprefix(model_layout.MODEL_DIR + "/")
        files[onnx_file] = export_onnx(network) if onnx is None else onnx
        info = CheckpointInfo(
            name=name,
            number=number,
            env_steps=env_steps,
            policy_config=network.config,
            model_metadata=None if model_metadata is None else model_metadata_to_dict(model_metadata),
            hyperparameters=None
            if hyperparameters is None
            else resolved_hyperparameters(hyperparameters, network.config.training_algorithm),
            created_unix_s=time.time(),
            versions=package_versions(),
            files={file: {"sha256": sha256_hex(data), "size_bytes": len(data)} for file, data in files.items()},
            extra=dict(extra or {}),
        )
        return CheckpointFiles(name, files, json.dumps(info.to_dict(), indent=1, sort_keys=True).encode())

    def publish(self, checkpoint: CheckpointFiles) -> None:
        """Write the files, the manifest last, then move the pointer (under `.lock`); no retention."""
        self.store.put_bytes(self.layout.lock, b"")
        for file_name, data in checkpoint.files.items():
            self.store.put_bytes(self.layout.key(model_layout.MODEL_DIR, file_name), data)
        self.store.put_bytes(self._file(checkpoint.name, MANIFEST_SUFFIX), checkpoint.manifest)  # marks it complete
        self.store.put_bytes(self.layout.coach_checkpoint, (checkpoint.name + "\n").encode())
        self.store.delete(self.layout.lock)

    def apply_retention(self) -> list[str]:
        """Delete checkpoints other than the `keep` newest, the best and the pointer's. Returns the deleted names."""
        complete = self.names()
        protected = set(complete[-self.keep :]) if self.keep > 0 else set()
        best_and_last = self.read_best_and_last()
        if best_and_last is not None and best_and_last.best is not None:
            protected.add(best_and_last.best.name)
        pointer = self.latest_name()
        if pointer is not None:
            protected.add(pointer)
        newest_kept = max((CheckpointName.parse(name).number for name in protected), default=-1)
        deleted = []
        for name, keys in sorted(self._files_by_checkpoint().items()):
            if name.name in protected or name.number > newest_kept:
                continue
            # Manifest first: from then on the checkpoint no longer counts as complete, whatever else remains.
            for key in sorted(keys, key=lambda key: not key.endswith(".ckpt" + MANIFEST_SUFFIX)):
                self.store.delete(key)
            deleted.append(name.name)
        return deleted

    def _files_by_checkpoint(self) -> dict[CheckpointName, list[str]]:
        """Every key of model/ that belongs to a numbered checkpoint, grouped by checkpoint."""
        groups: dict[CheckpointName, list[str]] = {}
        numbers: dict[int, list[str]] = {}
        for key in self.store.list_keys(self.layout.model_dir):
            file_name = key.rsplit("/", 1)[-1]
            name = CheckpointName.of_file(file_name)
            if name is not None:
                groups.setdefault(name, []).append(key)
            number = model_layout.inference_model_number(file_name)
            if number is not None and file_name.endswith(".onnx"):
                numbers.setdefault(number, []).append(key)
        for name, keys in groups.items():
            keys.extend(numbers.pop(name.number, []))
        return groups

    def write_best_and_last(self, best: CheckpointRecord | None, last: CheckpointRecord | None) -> None:
        self.store.put_bytes(self.layout.deepracer_checkpoints, best_and_last_to_bytes(best, last))

    def record_evaluation(
        self, name: str, avg_eval_metric: float, time_stamp: float, higher_is_better: bool = True
    ) -> BestAndLast:
        """`name` becomes the last checkpoint, and the best by DeepRacer's rule (best_and_last.after_evaluation)."""
        CheckpointName.parse(name)
        record = CheckpointRecord(name, float(avg_eval_metric), float(time_stamp))
        updated = after_evaluation(self.read_best_and_last(), record, higher_is_better)
        self.write_best_and_last(updated.best, updated.last)
        return updated

    def put_model_metadata(self, model_metadata: ModelMetadata) -> None:
        """`model/model_metadata.json`."""
        data = model_metadata_to_dict(model_metadata)
        self.store.put_bytes(self.layout.model_metadata, json.dumps(data, indent=4).encode())

    def put_hyperparameters(self, hyperparameters: Hyperparameters) -> None:
        """`ip/hyperparameters.json`: the resolved values in DeepRacer's byte format."""
        self.store.put_bytes(self.layout.hyperparameters, hyperparameters_to_json_bytes(hyperparameters))
