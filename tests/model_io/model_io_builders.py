"""Synthetic model folders in DeepRacer's layout, built from the real files in ../shared/deepracer-data."""

from __future__ import annotations

import io
import json
import tarfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from onnx import TensorProto, helper, numpy_helper

from racer.model_io import ProblemCode
from tests.shared_data import SHARED_DATA

Code = ProblemCode

CONFIG = SHARED_DATA
"""Test modules that use these builders declare `pytestmark = pytest.mark.usefixtures("deepracer_data")`."""

TF_PARTS = ("data-00000-of-00001", "index", "meta")


@dataclass(frozen=True)
class RealFiles:
    model_metadata: bytes
    hyperparameters: bytes
    training_params: bytes
    reward_function: bytes
    training_metrics: bytes


def real_files(data_root: Path = CONFIG) -> RealFiles:
    return RealFiles(
        model_metadata=(data_root / "config" / "console2022_model_metadata.json").read_bytes(),
        hyperparameters=(data_root / "config" / "console2022_ip_hyperparameters.json").read_bytes(),
        training_params=(data_root / "config" / "simapp_sample-training_params.yaml").read_bytes(),
        reward_function=(data_root / "reward_functions" / "awsdoc_example_1.py").read_bytes(),
        training_metrics=(data_root / "metrics" / "console2022_TrainingMetrics.json").read_bytes(),
    )


def write(root: Path, key: str, data: bytes | str) -> Path:
    path = root / key
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(data.encode() if isinstance(data, str) else data)
    return path


def tf_checkpoint(root: Path, name: str, parts: tuple[str, ...] = TF_PARTS, size: int = 64) -> None:
    """The files TensorFlow writes for checkpoint `name` (content is filler: nothing here reads TF)."""
    for part in parts:
        write(root, f"model/{name}.{part}", bytes([len(part)]) * size)


def deepracer_model(
    root: Path,
    *,
    checkpoints: tuple[str, ...] = ("3_Step-124.ckpt", "4_Step-162.ckpt"),
    coach: str | None = "4_Step-162.ckpt",
    best: str | None = None,
    last: str | None = None,
    metadata_at_root: bool = False,
) -> Path:
    """A console-style model prefix: TF checkpoints, model_<N>.pb, pointers, configs, metrics."""
    files = real_files()
    for name in checkpoints:
        tf_checkpoint(root, name)
        write(root, f"model/model_{name.split('_')[0]}.pb", b"frozen graph " + name.encode())
    if coach is not None:
        write(root, "model/.coach_checkpoint", coach)
    if best is not None and last is not None:
        write(
            root,
            "model/deepracer_checkpoints.json",
            json.dumps(
                {
                    "best_checkpoint": {"name": best, "avg_eval_metric": 58.9, "time_stamp": 5502.2},
                    "last_checkpoint": {"name": last, "avg_eval_metric": 18.9, "time_stamp": 5734.3},
                }
            ),
        )
    write(root, "model_metadata.json" if metadata_at_root else "model/model_metadata.json", files.model_metadata)
    write(root, "ip/hyperparameters.json", files.hyperparameters)
    write(root, "training_params.yaml", files.training_params)
    write(root, "reward_function.py", files.reward_function)
    write(root, "metrics/TrainingMetrics.json", files.training_metrics)
    return root


def pack(folder: Path, archive: Path, wrapper: str | None = None) -> Path:
    with tarfile.open(archive, "w:gz") as tar:
        for path in sorted(folder.rglob("*")):
            if path.is_file():
                relative = path.relative_to(folder).as_posix()
                tar.add(path, arcname=f"{wrapper}/{relative}" if wrapper else relative)
    return archive


def tiny_onnx(num_outputs: int) -> bytes:
    """An inference graph shaped like racer's: raw grayscale [1,120,160,1] in, action probabilities out."""
    weights = np.random.default_rng(0).normal(size=(120 * 160, num_outputs)).astype(np.float32) * 1e-3
    graph = helper.make_graph(
        [
            helper.make_node("Reshape", ["observation", "shape"], ["flat"]),
            helper.make_node("MatMul", ["flat", "weights"], ["logits"]),
            helper.make_node("Softmax", ["logits"], ["probabilities"], axis=-1),
        ],
        "policy",
        [helper.make_tensor_value_info("observation", TensorProto.FLOAT, [1, 120, 160, 1])],
        [helper.make_tensor_value_info("probabilities", TensorProto.FLOAT, [1, num_outputs])],
        [
            numpy_helper.from_array(np.array([1, 120 * 160], dtype=np.int64), "shape"),
            numpy_helper.from_array(weights, "weights"),
        ],
    )
    return helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)]).SerializeToString()


def remove(key: str) -> Callable[[Path], None]:
    return lambda root: (root / key).unlink()


def replace(key: str, data: bytes | str) -> Callable[[Path], None]:
    return lambda root: write(root, key, data)


def edit_metadata_speed(root: Path) -> None:
    document = json.loads((root / "model/model_metadata.json").read_bytes())
    document["action_space"][3]["speed"] = 7.0
    write(root, "model/model_metadata.json", json.dumps(document))


def second_metadata_differs(root: Path) -> None:
    document = json.loads((root / "model/model_metadata.json").read_bytes())
    document["action_space"] = document["action_space"][:5]
    write(root, "model_metadata.json", json.dumps(document))


def seed_coach_example(root: Path) -> None:
    """The seed's failing example: pointer 13_Step-25173.ckpt, files only for 13_Step-25174/5 and 14_Step-3456."""
    for name in ("3_Step-124.ckpt", "4_Step-162.ckpt"):
        for part in ("data-00000-of-00001", "index", "meta"):
            (root / f"model/{name}.{part}").unlink()
    for name in ("13_Step-25174.ckpt", "13_Step-25175.ckpt", "14_Step-3456.ckpt"):
        tf_checkpoint(root, name)
    write(root, "model/.coach_checkpoint", "13_Step-25173.ckpt\n")


def seed_deepracer_checkpoints_example(root: Path) -> None:
    """The seed's failing example: best 319_Step-43282 / last 20_Step-43482, files only for 320..322."""
    for name in ("320_Step-43278.ckpt", "321_Step-43280.ckpt", "322_Step-43282.ckpt"):
        tf_checkpoint(root, name)
    write(
        root,
        "model/deepracer_checkpoints.json",
        json.dumps(
            {"best_checkpoint": {"name": "319_Step-43282.ckpt"}, "last_checkpoint": {"name": "20_Step-43482.ckpt"}}
        ),
    )


def car_bundle_without_model(root: Path) -> None:
    buffer = io.BytesIO()
    with tarfile.open(fileobj=buffer, mode="w:gz") as bundle:
        data = (root / "model/model_metadata.json").read_bytes()
        info = tarfile.TarInfo("model_metadata.json")
        info.size = len(data)
        bundle.addfile(info, io.BytesIO(data))
    write(root, "model.tar.gz", buffer.getvalue())


BROKEN: dict[str, tuple[Callable[[Path], None], ProblemCode]] = {
    "no reward_function.py": (remove("reward_function.py"), Code.FILE_DOES_NOT_EXIST),
    "no training_params.yaml": (remove("training_params.yaml"), Code.FILE_DOES_NOT_EXIST),
    "no ip/hyperparameters.json": (remove("ip/hyperparameters.json"), Code.FILE_DOES_NOT_EXIST),
    "no model_metadata.json": (remove("model/model_metadata.json"), Code.FILE_DOES_NOT_EXIST),
    "no pointer at all": (remove("model/.coach_checkpoint"), Code.COACH_CHECKPOINT_DOES_NOT_EXIST),
    "pointer names a missing checkpoint (seed)": (seed_coach_example, Code.CHECKPOINT_FILES_DOES_NOT_EXIST),
    "deepracer_checkpoints.json names missing checkpoints (seed)": (
        seed_deepracer_checkpoints_example,
        Code.CHECKPOINT_FILES_DOES_NOT_EXIST,
    ),
    "named checkpoint lacks its data file": (
        remove("model/4_Step-162.ckpt.data-00000-of-00001"),
        Code.CHECKPOINT_FILES_DOES_NOT_EXIST,
    ),
    "named checkpoint lacks its index": (remove("model/4_Step-162.ckpt.index"), Code.CHECKPOINT_FILES_DOES_NOT_EXIST),
    "metadata speed out of range": (edit_metadata_speed, Code.MODEL_VALIDATION_SERVICE_ERROR),
    "metadata is not JSON": (
        replace("model/model_metadata.json", '{"action_space": ['),
        Code.MODEL_VALIDATION_SERVICE_ERROR,
    ),
    "two metadata copies differ": (second_metadata_differs, Code.MODEL_VALIDATION_SERVICE_ERROR),
    "two hyperparameters copies differ": (
        replace("hyperparameters.json", json.dumps({"batch_size": 32})),
        Code.MODEL_VALIDATION_SERVICE_ERROR,
    ),
    "pointer does not follow <N>_Step-<M>.ckpt": (
        replace("model/.coach_checkpoint", "model.ckpt"),
        Code.MODEL_VALIDATION_SERVICE_ERROR,
    ),
    "pointer holds two lines": (
        replace("model/.coach_checkpoint", "4_Step-162.ckpt\n3_Step-124.ckpt\n"),
        Code.MODEL_VALIDATION_SERVICE_ERROR,
    ),
    "deepracer_checkpoints.json without last_checkpoint": (
        replace("model/deepracer_checkpoints.json", json.dumps({"best_checkpoint": {"name": "4_Step-162.ckpt"}})),
        Code.MODEL_VALIDATION_SERVICE_ERROR,
    ),
    "hyperparameter out of the console's range": (
        replace("ip/hyperparameters.json", json.dumps({"batch_size": 64, "lr": 5.0})),
        Code.MODEL_VALIDATION_SERVICE_ERROR,
    ),
    "training_params.yaml is not YAML": (
        replace("training_params.yaml", "WORLD_NAME: [unclosed\n"),
        Code.MODEL_VALIDATION_SERVICE_ERROR,
    ),
    "reward function has no reward_function": (
        replace("reward_function.py", "def reward(params):\n    return 1.0\n"),
        Code.MODEL_VALIDATION_SERVICE_ERROR,
    ),
    "reward function is not Python": (
        replace("reward_function.py", "def reward_function(params)\n  return 1\n"),
        Code.MODEL_VALIDATION_SERVICE_ERROR,
    ),
    "inference model outputs the wrong number of actions": (
        replace("model/model_4.onnx", tiny_onnx(5)),
        Code.MODEL_VALIDATION_SERVICE_ERROR,
    ),
    "inference model is not ONNX": (
        replace("model/model_4.onnx", b"not a protobuf at all"),
        Code.MODEL_VALIDATION_SERVICE_ERROR,
    ),
    "car bundle without the inference model": (car_bundle_without_model, Code.MODEL_VALIDATION_SERVICE_ERROR),
}


def upload(folder: Path, store, prefix: str) -> list[str]:
    """Put every file of `folder` under `prefix/` in an object store; returns the keys."""
    keys = []
    for path in sorted(folder.rglob("*")):
        if path.is_file():
            key = f"{prefix}/{path.relative_to(folder).as_posix()}"
            store.put_bytes(key, path.read_bytes())
            keys.append(key)
    return keys
