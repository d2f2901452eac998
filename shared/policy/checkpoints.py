"""Checkpoints in DeepRacer's `model/` layout, through any ObjectStore (S3/MinIO or a local directory).

Keys written under `<model_prefix>/` (reference section 5.1; N = checkpoint number from 0, M = env steps consumed):

    model/<N>_Step-<M>.ckpt.weights.safetensors     network weights (state_dict names, float32, no pickle)
    model/<N>_Step-<M>.ckpt.optimizer.safetensors   optimiser tensors, keyed "<parameter name>.<state key>"
    model/<N>_Step-<M>.ckpt.optimizer.json          optimiser scalars (Adam step counts, lr, betas, eps, ...)
    model/<N>_Step-<M>.ckpt.json                    what produced it: policy config, model_metadata, hyperparameters,
                                                    versions, sha256 + size of every file above (written last)
    model/model_<N>.onnx                            inference model: inputs named by sensor, raw 0-255 grayscale
                                                    float [1, 120, 160, C] (lidar [1, n]); output "policy" = action
                                                    probabilities [1, num_actions] or the Gaussian mean [1, 2]
    model/.coach_checkpoint                         one line, the newest complete checkpoint, e.g. "3_Step-1234.ckpt"
    model/.lock                                     present only while a checkpoint is being uploaded
    model/deepracer_checkpoints.json                {"best_checkpoint": {name, avg_eval_metric, time_stamp},
                                                     "last_checkpoint": {...}}
    model/model_metadata.json                       put_model_metadata()
    ip/hyperparameters.json                         put_hyperparameters() (resolved values, DeepRacer's format)

Publishing is atomic for readers: `.lock` goes up, every file of checkpoint N is written (the `.ckpt.json` manifest
last), then `.coach_checkpoint` moves to N, then `.lock` goes away. A reader following the pointer therefore never
meets a missing or half-written file, and `load()` verifies sizes and sha256 anyway. Retention, after the pointer
moved: keep the 4 newest checkpoints plus the best one named in deepracer_checkpoints.json; delete the others with
their `model_<N>.onnx` (DeepRacer's NUM_MODELS_TO_KEEP = 4, best re-queued).

Public API
----------
    checkpoints = CheckpointStore(store, model_prefix)
    name = checkpoints.save(N, M, network, trainer.optimizer, model_metadata, hyperparameters)   -> "N_Step-M.ckpt"
    checkpoints.latest_name() -> "3_Step-1234.ckpt" | None          (the pointer)
    checkpoints.names() -> complete checkpoints, oldest first
    checkpoints.select("best" | "last" | name) -> name
    number, env_steps = checkpoints.restore(name, network, optimizer=None)   (resume; weights only without optimizer)
    loaded = checkpoints.load(name=None)    -> LoadedCheckpoint(info, network_state, optimizer_state)
    network = checkpoints.load_policy(name=None)    -> ActorCritic in eval mode (workers)
    load_optimizer_state(optimizer, network, loaded.optimizer_state)    (restores channels-last strides too)
    checkpoints.record_evaluation(name, avg_eval_metric, time_stamp)    DeepRacer's best/last rule
    checkpoints.write_best_and_last(best, last), checkpoints.read_best_and_last() -> BestAndLast | None
    checkpoints.read_best_and_last() -> BestAndLast | None
    export_onnx(network) -> bytes
"""

from __future__ import annotations

import hashlib
import io
import json
import platform
import re
import time
import warnings
from collections.abc import Mapping
from dataclasses import dataclass
from importlib import metadata as package_metadata

import torch
from safetensors.torch import load as load_safetensors
from safetensors.torch import save as save_safetensors
from torch import nn

from racer.shared.deepracer.hyperparameters import (
    Hyperparameters,
    hyperparameters_to_json_bytes,
    resolved_hyperparameters,
)
from racer.shared.deepracer.model_metadata import ModelMetadata, model_metadata_to_dict
from racer.shared.policy.networks import LOG_STD_MAX, LOG_STD_MIN, ActorCritic, PolicyConfig
from racer.shared.store import ObjectNotFoundError, ObjectStore, join_key

__all__ = [
    "BestAndLast",
    "CHECKPOINT_NAME",
    "CheckpointError",
    "CheckpointInfo",
    "CheckpointRecord",
    "CheckpointStore",
    "LoadedCheckpoint",
    "NUM_CHECKPOINTS_TO_KEEP",
    "checkpoint_name",
    "export_onnx",
    "load_optimizer_state",
    "optimizer_state_from_files",
    "optimizer_state_to_files",
    "parse_checkpoint_name",
]

CHECKPOINT_NAME = re.compile(r"^(\d+)_Step-(\d+)\.ckpt$")
NUM_CHECKPOINTS_TO_KEEP = 4
FORMAT = "racer-checkpoint-1"
ONNX_OPSET = 17

POINTER_FILE = ".coach_checkpoint"
LOCK_FILE = ".lock"
BEST_AND_LAST_FILE = "deepracer_checkpoints.json"
WEIGHTS_SUFFIX = ".weights.safetensors"
OPTIMIZER_TENSORS_SUFFIX = ".optimizer.safetensors"
OPTIMIZER_SCALARS_SUFFIX = ".optimizer.json"
MANIFEST_SUFFIX = ".json"


class CheckpointError(Exception):
    """A checkpoint that is missing, incomplete or corrupt; the message names the key."""


def checkpoint_name(number: int, env_steps: int) -> str:
    return f"{number}_Step-{env_steps}.ckpt"


def parse_checkpoint_name(name: str) -> tuple[int, int]:
    """`13_Step-25173.ckpt` -> (13, 25173); ValueError otherwise."""
    match = CHECKPOINT_NAME.match(name)
    if match is None:
        raise ValueError(f"{name!r} is not a checkpoint name like 13_Step-25173.ckpt")
    return int(match.group(1)), int(match.group(2))


# --------------------------------------------------------------------------------------------------------------------
# Data classes


@dataclass(frozen=True)
class CheckpointInfo:
    """The `.ckpt.json` manifest."""

    name: str
    number: int
    env_steps: int
    policy_config: PolicyConfig
    model_metadata: dict | None
    hyperparameters: dict | None
    created_unix_s: float
    versions: dict[str, str]
    files: dict[str, dict]
    """file name -> {"sha256": hex, "size_bytes": int}."""
    extra: dict

    def to_dict(self) -> dict:
        return {
            "format": FORMAT,
            "name": self.name,
            "number": self.number,
            "env_steps": self.env_steps,
            "policy_config": self.policy_config.to_dict(),
            "model_metadata": self.model_metadata,
            "hyperparameters": self.hyperparameters,
            "created_unix_s": self.created_unix_s,
            "versions": self.versions,
            "files": self.files,
            "extra": self.extra,
        }

    @classmethod
    def from_dict(cls, data: Mapping) -> CheckpointInfo:
        if data.get("format") != FORMAT:
            raise CheckpointError(f"checkpoint manifest format {data.get('format')!r}, expected {FORMAT!r}")
        return cls(
            name=str(data["name"]),
            number=int(data["number"]),
            env_steps=int(data["env_steps"]),
            policy_config=PolicyConfig.from_dict(data["policy_config"]),
            model_metadata=data.get("model_metadata"),
            hyperparameters=data.get("hyperparameters"),
            created_unix_s=float(data["created_unix_s"]),
            versions=dict(data.get("versions", {})),
            files=dict(data["files"]),
            extra=dict(data.get("extra", {})),
        )


@dataclass(frozen=True)
class LoadedCheckpoint:
    info: CheckpointInfo
    network_state: dict[str, torch.Tensor]
    optimizer_state: dict | None
    """In torch's `Optimizer.state_dict()` form, for `load_optimizer_state`; None if the checkpoint has none."""


@dataclass(frozen=True)
class CheckpointRecord:
    """One entry of deepracer_checkpoints.json."""

    name: str
    avg_eval_metric: float | None
    time_stamp: float | None

    def to_dict(self) -> dict:
        return {"name": self.name, "avg_eval_metric": self.avg_eval_metric, "time_stamp": self.time_stamp}


@dataclass(frozen=True)
class BestAndLast:
    best: CheckpointRecord | None
    last: CheckpointRecord | None


# --------------------------------------------------------------------------------------------------------------------
# Serialisation helpers (no pickle anywhere)


def _sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def _tensors_to_bytes(tensors: Mapping[str, torch.Tensor]) -> bytes:
    return save_safetensors({name: tensor.detach().contiguous() for name, tensor in tensors.items()})


def optimizer_state_to_files(
    optimizer: torch.optim.Optimizer, network: nn.Module
) -> tuple[dict[str, torch.Tensor], dict]:
    """Split an optimiser's state into tensors (keyed "<parameter name>.<state key>") and JSON-able scalars.

    The optimiser must have been built over `network.parameters()` (any grouping); parameters are identified by
    their names in the network, so the state survives a rebuild of the network.
    """
    names = {id(parameter): name for name, parameter in network.named_parameters()}
    state_dict = optimizer.state_dict()
    index_to_name = {}
    index = 0
    for group in optimizer.param_groups:
        for parameter in group["params"]:
            if id(parameter) not in names:
                raise ValueError("the optimiser holds a parameter that is not part of the network")
            index_to_name[index] = names[id(parameter)]
            index += 1
    tensors: dict[str, torch.Tensor] = {}
    scalars: dict[str, dict] = {}
    for parameter_index, state in state_dict["state"].items():
        name = index_to_name[parameter_index]
        for key, value in state.items():
            if isinstance(value, torch.Tensor) and value.dim() > 0:
                tensors[f"{name}.{key}"] = value
            elif isinstance(value, torch.Tensor):
                dtype = str(value.dtype).removeprefix("torch.")
                scalars.setdefault(name, {})[key] = {"value": value.item(), "dtype": dtype}
            else:
                scalars.setdefault(name, {})[key] = {"value": value}
    groups = []
    for group in state_dict["param_groups"]:
        settings = {key: list(value) if isinstance(value, tuple) else value for key, value in group.items()}
        del settings["params"]
        groups.append({"settings": settings, "params": [index_to_name[i] for i in group["params"]]})
    return tensors, {"type": type(optimizer).__name__, "param_groups": groups, "scalar_state": scalars}


def optimizer_state_from_files(tensors: Mapping[str, torch.Tensor], scalars: Mapping, network: nn.Module) -> dict:
    """The inverse of `optimizer_state_to_files`, as a torch optimiser state_dict (parameter indices in stored order)."""
    known = dict(network.named_parameters())
    state: dict[int, dict] = {}
    param_groups = []
    index = 0
    for group in scalars["param_groups"]:
        indices = []
        for name in group["params"]:
            if name not in known:
                raise CheckpointError(f"optimiser state names parameter {name!r}, which this network does not have")
            entry: dict = {}
            for key, item in scalars["scalar_state"].get(name, {}).items():
                dtype = item.get("dtype")
                entry[key] = torch.tensor(item["value"], dtype=getattr(torch, dtype)) if dtype else item["value"]
            prefix = f"{name}."
            for tensor_name, tensor in tensors.items():
                if tensor_name.startswith(prefix) and "." not in tensor_name[len(prefix) :]:
                    entry[tensor_name[len(prefix) :]] = tensor
            if entry:
                state[index] = entry
            indices.append(index)
            index += 1
        settings = {key: (tuple(value) if key == "betas" else value) for key, value in group["settings"].items()}
        param_groups.append({**settings, "params": indices})
    return {"state": state, "param_groups": param_groups}


def load_optimizer_state(optimizer: torch.optim.Optimizer, network: nn.Module, optimizer_state: Mapping) -> None:
    """`optimizer.load_state_dict` plus one fix: state tensors get their parameter's memory layout back.

    safetensors stores contiguous tensors; the conv weights are channels-last, and the fused Adam kernel silently
    computes wrong updates when a moment tensor's strides differ from its parameter's.
    """
    optimizer.load_state_dict(optimizer_state)
    for parameter in network.parameters():
        state = optimizer.state.get(parameter, {})
        for key, value in list(state.items()):
            same_shape = isinstance(value, torch.Tensor) and value.shape == parameter.shape
            if same_shape and value.stride() != parameter.stride():
                state[key] = torch.empty_like(parameter, dtype=value.dtype).copy_(value)


class _InferenceModel(nn.Module):
    """Positional inputs in sorted sensor order -> the policy output, for the ONNX exporter."""

    def __init__(self, network: ActorCritic):
        super().__init__()
        self.network = network

    def forward(self, *inputs: torch.Tensor) -> torch.Tensor:
        return self.network.policy_output(dict(zip(self.network.input_names, inputs, strict=True)))


def export_onnx(network: ActorCritic) -> bytes:
    """The inference model of a network: inputs named by sensor (raw 0-255 grayscale float [1, 120, 160, C],
    lidar [1, n]), output `policy` = action probabilities or the Gaussian mean in [-1, 1]. Policy tower only."""
    examples = tuple(torch.zeros(1, *spec.shape) for spec in network.config.inputs)
    buffer = io.BytesIO()
    was_training = network.training
    network.eval()
    try:
        with warnings.catch_warnings():
            # The torch.export-based exporter needs onnxscript, which is not a dependency; the TorchScript one
            # handles these plain conv/dense graphs and warns that it is the legacy path.
            warnings.simplefilter("ignore", DeprecationWarning)
            torch.onnx.export(
                _InferenceModel(network),
                examples,
                buffer,
                input_names=list(network.input_names),
                output_names=["policy"],
                opset_version=ONNX_OPSET,
                dynamo=False,
            )
    finally:
        network.train(was_training)
    return buffer.getvalue()


def _versions() -> dict[str, str]:
    versions = {"python": platform.python_version(), "torch": torch.__version__}
    for package in ("racer", "safetensors", "onnx"):
        try:
            versions[package] = package_metadata.version(package)
        except package_metadata.PackageNotFoundError:
            versions[package] = "unknown"
    return versions


def _record(data: object) -> CheckpointRecord | None:
    if not isinstance(data, Mapping) or "name" not in data:
        return None
    metric = data.get("avg_eval_metric", data.get("avg_comp_pct"))  # older DRfC files use avg_comp_pct
    stamp = data.get("time_stamp")
    return CheckpointRecord(
        str(data["name"]), None if metric is None else float(metric), None if stamp is None else float(stamp)
    )


# --------------------------------------------------------------------------------------------------------------------
# The store


class CheckpointStore:
    """DeepRacer's `model/` folder of one training run, in an ObjectStore under `model_prefix`."""

    def __init__(self, store: ObjectStore, model_prefix: str, keep: int = NUM_CHECKPOINTS_TO_KEEP):
        self.store = store
        self.model_prefix = model_prefix
        self.keep = keep

    def key(self, *parts: str) -> str:
        return join_key(self.model_prefix, *parts)

    def model_key(self, file_name: str) -> str:
        return self.key("model", file_name)

    # -- reading -----------------------------------------------------------------------------------------------------

    def latest_name(self) -> str | None:
        """The checkpoint `.coach_checkpoint` names, or None before checkpoint 0 is published."""
        try:
            text = self.store.get_bytes(self.model_key(POINTER_FILE)).decode("utf-8").strip()
        except ObjectNotFoundError:
            return None
        parse_checkpoint_name(text)
        return text

    def is_locked(self) -> bool:
        """True while a checkpoint upload is in progress (DeepRacer's rollout workers wait for it to clear)."""
        return self.store.exists(self.model_key(LOCK_FILE))

    def names(self) -> list[str]:
        """Complete checkpoints (manifest present), oldest first."""
        names = []
        for key in self.store.list_keys(self.model_key("")):
            file_name = key.rsplit("/", 1)[-1]
            if file_name.endswith(".ckpt" + MANIFEST_SUFFIX) and CHECKPOINT_NAME.match(file_name[: -len(MANIFEST_SUFFIX)]):
                names.append(file_name[: -len(MANIFEST_SUFFIX)])
        return sorted(names, key=lambda name: parse_checkpoint_name(name)[0])

    def read_info(self, name: str) -> CheckpointInfo:
        try:
            data = json.loads(self.store.get_bytes(self.model_key(name + MANIFEST_SUFFIX)))
        except ObjectNotFoundError:
            if self.store.exists(self.model_key(name + ".index")):
                raise CheckpointError(
                    f"{self.store.describe()}: {self.model_key(name)} is a TensorFlow checkpoint (AWS console or "
                    f"DeepRacer-for-Cloud): its files are kept, but racer evaluates and clones only the PyTorch "
                    f"checkpoints it trains itself") from None
            raise CheckpointError(f"{self.store.describe()}: checkpoint {name} has no manifest "
                                  f"{self.model_key(name + MANIFEST_SUFFIX)!r} (not saved, or deleted by retention)") from None
        return CheckpointInfo.from_dict(data)

    def _read_verified(self, info: CheckpointInfo, file_name: str) -> bytes:
        key = self.model_key(file_name)
        try:
            data = self.store.get_bytes(key)
        except ObjectNotFoundError:
            raise CheckpointError(f"{self.store.describe()}: {key!r} of checkpoint {info.name} is missing") from None
        expected = info.files[file_name]
        if len(data) != expected["size_bytes"] or _sha256(data) != expected["sha256"]:
            raise CheckpointError(f"{self.store.describe()}: {key!r} does not match its manifest (corrupt or replaced)")
        return data

    def load(self, name: str | None = None) -> LoadedCheckpoint:
        """Weights, optimiser state and manifest of `name` (default: the pointer's checkpoint)."""
        name = name or self.latest_name()
        if name is None:
            raise CheckpointError(f"{self.store.describe()}: no {self.model_key(POINTER_FILE)!r}; nothing to load")
        info = self.read_info(name)
        network_state = load_safetensors(self._read_verified(info, name + WEIGHTS_SUFFIX))
        optimizer_state = None
        if name + OPTIMIZER_TENSORS_SUFFIX in info.files:
            tensors = load_safetensors(self._read_verified(info, name + OPTIMIZER_TENSORS_SUFFIX))
            scalars = json.loads(self._read_verified(info, name + OPTIMIZER_SCALARS_SUFFIX))
            network = ActorCritic(info.policy_config)
            optimizer_state = optimizer_state_from_files(tensors, scalars, network)
        return LoadedCheckpoint(info=info, network_state=network_state, optimizer_state=optimizer_state)

    def restore(self, name: str, network: ActorCritic, optimizer: torch.optim.Optimizer | None = None) -> tuple[int, int]:
        """Load a checkpoint into an existing network (and optimiser, if given). Returns (number, env_steps).

        The network must have the checkpoint's structure (same PolicyConfig); without an optimiser only the weights
        are restored (e.g. cloning a pretrained model).
        """
        loaded = self.load(name) if optimizer is not None else None
        info = loaded.info if loaded is not None else self.read_info(name)
        if info.policy_config != network.config:
            raise CheckpointError(f"checkpoint {name} was saved from a different network: {info.policy_config} "
                                  f"vs {network.config}")
        if loaded is not None:
            network.load_state_dict(loaded.network_state)
            if loaded.optimizer_state is None:
                raise CheckpointError(f"checkpoint {name} has no optimiser state to restore")
            load_optimizer_state(optimizer, network, loaded.optimizer_state)
        else:
            network.load_state_dict(load_safetensors(self._read_verified(info, name + WEIGHTS_SUFFIX)))
        return info.number, info.env_steps

    def select(self, which: str) -> str:
        """`best` (deepracer_checkpoints.json's best, else the pointer), `last` (the pointer) or a checkpoint name."""
        if which == "last" or which == "best":
            best_and_last = self.read_best_and_last() if which == "best" else None
            if best_and_last is not None and best_and_last.best is not None and best_and_last.best.name in self.names():
                return best_and_last.best.name
            name = self.latest_name()
            if name is None:
                raise CheckpointError(f"{self.store.describe()}: {self.model_key(POINTER_FILE)!r} is missing; no checkpoint")
            return name
        parse_checkpoint_name(which)
        if which not in self.names():
            raise CheckpointError(f"{self.store.describe()}: no complete checkpoint {which} under {self.model_key('')!r}; "
                                  f"have {', '.join(self.names()) or 'none'}")
        return which

    def load_policy(self, name: str | None = None) -> ActorCritic:
        """The network of a checkpoint, ready to act (eval mode). Reads the weights only, not the optimiser."""
        name = name or self.latest_name()
        if name is None:
            raise CheckpointError(f"{self.store.describe()}: no {self.model_key(POINTER_FILE)!r}; nothing to load")
        info = self.read_info(name)
        network = ActorCritic(info.policy_config)
        network.load_state_dict(load_safetensors(self._read_verified(info, name + WEIGHTS_SUFFIX)))
        return network.eval()

    def load_inference_policy(self, name: str | None = None):
        """The checkpoint's exported ONNX model run with ONNX Runtime: what the rollout and evaluation workers act with.

        Same actions and log-probabilities as `load_policy(name).act` (see racer.shared.policy.onnx_policy), about
        1.7x faster per observation on one CPU thread, because single-frame inference is mostly framework overhead.
        No torch network is built: workers load a policy every iteration, so this stays cheap.
        """
        from racer.shared.policy.onnx_policy import OnnxPolicy

        name = name or self.latest_name()
        if name is None:
            raise CheckpointError(f"{self.store.describe()}: no {self.model_key(POINTER_FILE)!r}; nothing to load")
        info = self.read_info(name)
        log_std = None
        if info.policy_config.is_continuous:  # the Gaussian's state-independent log-std is a weight, not in the graph
            weights = load_safetensors(self._read_verified(info, name + WEIGHTS_SUFFIX))
            log_std = weights["log_std"].clamp(LOG_STD_MIN, LOG_STD_MAX)
        onnx_bytes = self._read_verified(info, f"model_{info.number}.onnx")
        return OnnxPolicy(onnx_bytes, info.policy_config, log_std)

    def read_best_and_last(self) -> BestAndLast | None:
        try:
            data = json.loads(self.store.get_bytes(self.model_key(BEST_AND_LAST_FILE)))
        except ObjectNotFoundError:
            return None
        if not isinstance(data, Mapping):
            raise CheckpointError(f"{self.model_key(BEST_AND_LAST_FILE)!r} is not a JSON object")
        return BestAndLast(best=_record(data.get("best_checkpoint")), last=_record(data.get("last_checkpoint")))

    # -- writing -----------------------------------------------------------------------------------------------------

    def save(
        self,
        number: int,
        env_steps: int,
        network: ActorCritic,
        optimizer: torch.optim.Optimizer | None = None,
        model_metadata: ModelMetadata | None = None,
        hyperparameters: Hyperparameters | None = None,
        extra: Mapping | None = None,
    ) -> str:
        """Publish checkpoint `<number>_Step-<env_steps>.ckpt` and return its name.

        `model_metadata` and `hyperparameters` go into the manifest (as DeepRacer's dicts) so a checkpoint says what
        produced it. Retention runs after the pointer moved.
        """
        name = checkpoint_name(number, env_steps)
        files: dict[str, bytes] = {name + WEIGHTS_SUFFIX: _tensors_to_bytes(network.state_dict())}
        if optimizer is not None:
            tensors, scalars = optimizer_state_to_files(optimizer, network)
            files[name + OPTIMIZER_TENSORS_SUFFIX] = _tensors_to_bytes(tensors)
            files[name + OPTIMIZER_SCALARS_SUFFIX] = json.dumps(scalars, indent=1, sort_keys=True).encode()
        onnx_name = f"model_{number}.onnx"
        files[onnx_name] = export_onnx(network)
        info = CheckpointInfo(
            name=name,
            number=number,
            env_steps=env_steps,
            policy_config=network.config,
            model_metadata=None if model_metadata is None else model_metadata_to_dict(model_metadata),
            hyperparameters=None if hyperparameters is None else resolved_hyperparameters(hyperparameters),
            created_unix_s=time.time(),
            versions=_versions(),
            files={file: {"sha256": _sha256(data), "size_bytes": len(data)} for file, data in files.items()},
            extra=dict(extra or {}),
        )
        manifest = json.dumps(info.to_dict(), indent=1, sort_keys=True).encode()

        self.store.put_bytes(self.model_key(LOCK_FILE), b"")
        for file_name, data in files.items():
            self.store.put_bytes(self.model_key(file_name), data)
        self.store.put_bytes(self.model_key(name + MANIFEST_SUFFIX), manifest)  # last: marks the set complete
        self.store.put_bytes(self.model_key(POINTER_FILE), (name + "\n").encode())
        self.store.delete(self.model_key(LOCK_FILE))
        self.apply_retention()
        return name

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
        newest_kept = max((parse_checkpoint_name(name)[0] for name in protected), default=-1)
        groups = self._files_by_checkpoint()
        deleted = []
        for name, keys in sorted(groups.items(), key=lambda item: parse_checkpoint_name(item[0])[0]):
            number = parse_checkpoint_name(name)[0]
            if name in protected or number > newest_kept:
                continue
            # Manifest first: from then on the checkpoint no longer counts as complete, whatever else remains.
            for key in sorted(keys, key=lambda key: not key.endswith(".ckpt" + MANIFEST_SUFFIX)):
                self.store.delete(key)
            deleted.append(name)
        return deleted

    def _files_by_checkpoint(self) -> dict[str, list[str]]:
        """Every key of model/ that belongs to a numbered checkpoint, grouped by checkpoint name."""
        groups: dict[str, list[str]] = {}
        numbers: dict[int, list[str]] = {}
        for key in self.store.list_keys(self.model_key("")):
            file_name = key.rsplit("/", 1)[-1]
            head, separator, _ = file_name.partition(".ckpt.")
            if separator and CHECKPOINT_NAME.match(head + ".ckpt"):
                groups.setdefault(head + ".ckpt", []).append(key)
            onnx = re.match(r"^model_(\d+)\.onnx$", file_name)
            if onnx:
                numbers.setdefault(int(onnx.group(1)), []).append(key)
        for name, keys in groups.items():
            keys.extend(numbers.pop(parse_checkpoint_name(name)[0], []))
        return groups

    def write_best_and_last(self, best: CheckpointRecord | None, last: CheckpointRecord | None) -> None:
        data = {}
        if best is not None:
            data["best_checkpoint"] = best.to_dict()
        if last is not None:
            data["last_checkpoint"] = last.to_dict()
        self.store.put_bytes(self.model_key(BEST_AND_LAST_FILE), json.dumps(data).encode())

    def record_evaluation(
        self, name: str, avg_eval_metric: float, time_stamp: float, higher_is_better: bool = True
    ) -> BestAndLast:
        """DeepRacer's rule (TrainingMetrics.update): `name` becomes the last checkpoint, and the best one when its
        metric is at least as good as the best so far (ties go to the newer checkpoint). Progress and reward are
        higher-is-better; lap time is lower-is-better."""
        parse_checkpoint_name(name)
        record = CheckpointRecord(name, float(avg_eval_metric), float(time_stamp))
        current = self.read_best_and_last()
        best = current.best if current is not None else None
        if best is None or best.avg_eval_metric is None:
            best = record
        elif higher_is_better and record.avg_eval_metric >= best.avg_eval_metric:
            best = record
        elif not higher_is_better and record.avg_eval_metric <= best.avg_eval_metric:
            best = record
        self.write_best_and_last(best, record)
        return BestAndLast(best=best, last=record)

    def put_model_metadata(self, model_metadata: ModelMetadata) -> None:
        """`model/model_metadata.json`."""
        data = model_metadata_to_dict(model_metadata)
        self.store.put_bytes(self.model_key("model_metadata.json"), json.dumps(data, indent=4).encode())

    def put_hyperparameters(self, hyperparameters: Hyperparameters) -> None:
        """`ip/hyperparameters.json`: the resolved values in DeepRacer's byte format."""
        self.store.put_bytes(self.key("ip", "hyperparameters.json"), hyperparameters_to_json_bytes(hyperparameters))
