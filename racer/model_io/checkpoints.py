"""Which files of a model folder make a complete checkpoint, in either format, and the console importer's choice.

Names and keys are racer.shared.model_layout's. A checkpoint is the group of files in `model/` whose names start
with `<N>_Step-<M>.ckpt.`, in one of two formats:

* TensorFlow (DeepRacer console / SimApp): `.index` and every `.data-0000i-of-0000K` shard (`.meta` is
  optional for restoring and not required).
* racer (`racer.shared.policy.checkpoints`): the weights and the manifest (written last, it lists every file with
  size and sha256); the optimiser files when saved with the optimiser. The manifest's own list is checked by
  validation (validate.py).

`files` below is a listing of the model folder: keys relative to the model prefix.
"""

from __future__ import annotations

import re

from racer.shared import model_layout
from racer.shared.model_layout import MANIFEST_SUFFIX, RACER_CHECKPOINT_SUFFIXES, WEIGHTS_SUFFIX, CheckpointName

MODEL_DIR = model_layout.MODEL_DIR + "/"
_TF_DATA_SHARD = re.compile(r"^\.data-(?P<index>\d+)-of-(?P<count>\d+)$")


def checkpoint_files(name: CheckpointName, files: set[str] | dict[str, int]) -> list[str]:
    """Keys (relative to the model prefix) of every file of checkpoint `name`."""
    start = name.file(".")
    return sorted(key for key in files if key.startswith(start))


def inference_model_files(name: CheckpointName, files: set[str] | dict[str, int]) -> list[str]:
    """`model/model_<N>.pb` (TensorFlow frozen graph) and/or `model/model_<N>.onnx` (this system) for checkpoint N."""
    return sorted(key for key in (name.inference_model("pb"), name.inference_model("onnx")) if key in files)


def is_inference_model(key: str) -> bool:
    return key.startswith(MODEL_DIR) and model_layout.inference_model_number(key.removeprefix(MODEL_DIR)) is not None


def _suffixes(name: CheckpointName, files: set[str] | dict[str, int]) -> set[str]:
    """`.index`, `.weights.safetensors`, ... of the files checkpoint `name` has."""
    return {key.removeprefix(name.file("")) for key in checkpoint_files(name, files)}


def is_racer_checkpoint(name: CheckpointName, files: set[str] | dict[str, int]) -> bool:
    return bool(_suffixes(name, files) & set(RACER_CHECKPOINT_SUFFIXES))


def missing_parts(name: CheckpointName, files: set[str] | dict[str, int]) -> list[str]:
    """Files checkpoint `name` needs but lacks; `[]` means complete.

    If none of its files exist the answer is `model/<name>.*`. TensorFlow checkpoints need the `.index` and
    every `.data-i-of-K` shard; racer checkpoints need the weights and the manifest.
    """
    present = _suffixes(name, files)
    if not present:
        return [name.file(".*")]
    if present & set(RACER_CHECKPOINT_SUFFIXES):
        return [name.file(suffix) for suffix in (WEIGHTS_SUFFIX, MANIFEST_SUFFIX) if suffix not in present]
    missing: list[str] = []
    shards = [_TF_DATA_SHARD.match(suffix) for suffix in present]
    shard_counts = {int(match["count"]) for match in shards if match}
    if ".index" not in present:
        missing.append(name.file(".index"))
    if not shard_counts:
        missing.append(name.file(".data-00000-of-00001"))
    for count in shard_counts:
        for index in range(count):
            suffix = f".data-{index:05d}-of-{count:05d}"
            if suffix not in present:
                missing.append(name.file(suffix))
    return missing


def all_checkpoint_names(files: set[str] | dict[str, int]) -> list[CheckpointName]:
    names = {CheckpointName.of_file(key.removeprefix(MODEL_DIR)) for key in files if key.startswith(MODEL_DIR)}
    return sorted(name for name in names if name is not None)


def previous_checkpoint(name: CheckpointName, files: set[str] | dict[str, int]) -> CheckpointName | None:
    """The complete checkpoint with the highest number below `name`'s (the console's "second from the last")."""
    earlier = [
        other for other in all_checkpoint_names(files) if other.number < name.number and not missing_parts(other, files)
    ]
    return max(earlier, default=None)
