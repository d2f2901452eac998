"""DeepRacer checkpoint names, pointer files and the console importer's choice of checkpoints.

Names follow `<N>_Step-<M>.ckpt` (N = checkpoint number, M = total environment steps; reference §5.1).
A checkpoint is the group of files in `model/` whose names start with `<name>.`, in one of two formats:

* TensorFlow (DeepRacer console / SimApp): `.index` and every `.data-0000i-of-0000K` shard (`.meta` is
  optional for restoring and not required).
* racer (`racer.shared.policy.checkpoints`): `.weights.safetensors` and the `.json` manifest (written last,
  it lists every file with size and sha256); `.optimizer.safetensors` / `.optimizer.json` when saved with
  the optimiser. The manifest's own list is checked by validation (validate.py).
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass

CHECKPOINT_NAME = re.compile(r"^(?P<number>\d+)_Step-(?P<steps>\d+)\.ckpt$")
_TF_DATA_SHARD = re.compile(r"^data-(?P<index>\d+)-of-(?P<count>\d+)$")
RACER_WEIGHTS = "weights.safetensors"
RACER_MANIFEST = "json"
RACER_PARTS = frozenset({RACER_WEIGHTS, RACER_MANIFEST, "optimizer.safetensors", "optimizer.json"})
"""Suffixes racer's CheckpointStore writes after `<name>.` (its WEIGHTS_SUFFIX, MANIFEST_SUFFIX, OPTIMIZER_*)."""
_INFERENCE_MODEL = re.compile(r"^model_(?P<number>\d+)\.(?P<ext>pb|onnx)$")

MODEL_DIR = "model/"
COACH_CHECKPOINT = "model/.coach_checkpoint"
DEEPRACER_CHECKPOINTS = "model/deepracer_checkpoints.json"


@dataclass(frozen=True, order=True)
class CheckpointName:
    number: int
    steps: int

    @property
    def name(self) -> str:
        return f"{self.number}_Step-{self.steps}.ckpt"

    def __str__(self) -> str:
        return self.name


def parse_checkpoint_name(text: str) -> CheckpointName | None:
    """`13_Step-25173.ckpt` -> CheckpointName(13, 25173); anything else -> None."""
    match = CHECKPOINT_NAME.match(text)
    if match is None:
        return None
    return CheckpointName(int(match["number"]), int(match["steps"]))


def checkpoint_name_of_file(file_name: str) -> CheckpointName | None:
    """The checkpoint a file in `model/` belongs to (`3_Step-124.ckpt.index` -> 3_Step-124.ckpt)."""
    head, separator, _ = file_name.partition(".ckpt.")
    if not separator:
        return None
    return parse_checkpoint_name(head + ".ckpt")


def checkpoint_files(name: CheckpointName, files: set[str] | dict[str, int]) -> list[str]:
    """Keys (relative to the model prefix) of every file of checkpoint `name`."""
    start = f"{MODEL_DIR}{name.name}."
    return sorted(key for key in files if key.startswith(start))


def inference_model_files(name: CheckpointName, files: set[str] | dict[str, int]) -> list[str]:
    """`model/model_<N>.pb` (TensorFlow frozen graph) and/or `model/model_<N>.onnx` (this system) for checkpoint N."""
    candidates = (f"{MODEL_DIR}model_{name.number}.pb", f"{MODEL_DIR}model_{name.number}.onnx")
    return sorted(key for key in candidates if key in files)


def is_inference_model(key: str) -> bool:
    return key.startswith(MODEL_DIR) and _INFERENCE_MODEL.match(key.removeprefix(MODEL_DIR)) is not None


def is_racer_checkpoint(name: CheckpointName, files: set[str] | dict[str, int]) -> bool:
    present = {key.removeprefix(f"{MODEL_DIR}{name.name}.") for key in checkpoint_files(name, files)}
    return bool(present & RACER_PARTS)


def missing_parts(name: CheckpointName, files: set[str] | dict[str, int]) -> list[str]:
    """Files checkpoint `name` needs but lacks; `[]` means complete.

    If none of its files exist the answer is `model/<name>.*`. TensorFlow checkpoints need the `.index` and
    every `.data-i-of-K` shard; racer checkpoints need the weights and the manifest.
    """
    present = {key.removeprefix(f"{MODEL_DIR}{name.name}.") for key in checkpoint_files(name, files)}
    if not present:
        return [f"{MODEL_DIR}{name.name}.*"]
    missing: list[str] = []
    if present & RACER_PARTS:
        return [f"{MODEL_DIR}{name.name}.{suffix}" for suffix in (RACER_WEIGHTS, RACER_MANIFEST) if suffix not in present]
    shards = [_TF_DATA_SHARD.match(suffix) for suffix in present]
    shard_counts = {int(match["count"]) for match in shards if match}
    if "index" not in present:
        missing.append(f"{MODEL_DIR}{name.name}.index")
    if not shard_counts:
        missing.append(f"{MODEL_DIR}{name.name}.data-00000-of-00001")
    for count in shard_counts:
        for index in range(count):
            suffix = f"data-{index:05d}-of-{count:05d}"
            if suffix not in present:
                missing.append(f"{MODEL_DIR}{name.name}.{suffix}")
    return missing


def all_checkpoint_names(files: set[str] | dict[str, int]) -> list[CheckpointName]:
    names = {checkpoint_name_of_file(key.removeprefix(MODEL_DIR)) for key in files if key.startswith(MODEL_DIR)}
    return sorted(name for name in names if name is not None)


def previous_checkpoint(name: CheckpointName, files: set[str] | dict[str, int]) -> CheckpointName | None:
    """The complete checkpoint with the highest number below `name`'s (the console's "second from the last")."""
    earlier = [other for other in all_checkpoint_names(files)
               if other.number < name.number and not missing_parts(other, files)]
    return max(earlier, default=None)


def parse_coach_checkpoint(data: bytes) -> str:
    """The one name in `.coach_checkpoint`; ValueError if the file is not one line of text."""
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        raise ValueError("is not UTF-8 text") from None
    lines = [line.strip() for line in text.splitlines() if line.strip()]
    if len(lines) != 1:
        raise ValueError(f"must hold exactly one line (a checkpoint name), found {len(lines)}")
    return lines[0]


@dataclass(frozen=True)
class DeepRacerCheckpoints:
    best: str
    last: str


def parse_deepracer_checkpoints(data: bytes) -> DeepRacerCheckpoints:
    """`{"best_checkpoint": {"name": ...}, "last_checkpoint": {"name": ...}}`; ValueError naming the field."""
    try:
        document = json.loads(data)
    except (UnicodeDecodeError, json.JSONDecodeError) as error:
        raise ValueError(f"is not valid JSON ({error})") from None
    if not isinstance(document, dict):
        raise ValueError("must be a JSON object with best_checkpoint and last_checkpoint")
    names: dict[str, str] = {}
    for field_name in ("best_checkpoint", "last_checkpoint"):
        entry = document.get(field_name)
        if not isinstance(entry, dict) or not isinstance(entry.get("name"), str) or not entry["name"].strip():
            raise ValueError(f"{field_name}.name is missing or not a string")
        names[field_name] = entry["name"].strip()
    return DeepRacerCheckpoints(best=names["best_checkpoint"], last=names["last_checkpoint"])


def render_deepracer_checkpoints(best: CheckpointName, last: CheckpointName,
                                 best_metric: float | None = None, last_metric: float | None = None) -> bytes:
    """A deepracer_checkpoints.json naming `best` and `last` (metric fields only when known)."""
    def entry(name: CheckpointName, metric: float | None) -> dict[str, object]:
        return {"name": name.name} if metric is None else {"name": name.name, "avg_eval_metric": metric}

    return json.dumps({"best_checkpoint": entry(best, best_metric), "last_checkpoint": entry(last, last_metric)}).encode()
