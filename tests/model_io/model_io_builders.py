"""Synthetic model folders in DeepRacer's layout, built from the real files in ../shared/deepracer-data."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

CONFIG = Path(__file__).resolve().parents[2].parent / "shared" / "deepracer-data"

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


def deepracer_model(root: Path, *, checkpoints: tuple[str, ...] = ("3_Step-124.ckpt", "4_Step-162.ckpt"),
                    coach: str | None = "4_Step-162.ckpt", best: str | None = None, last: str | None = None,
                    metadata_at_root: bool = False) -> Path:
    """A console-style model prefix: TF checkpoints, model_<N>.pb, pointers, configs, metrics."""
    files = real_files()
    for name in checkpoints:
        tf_checkpoint(root, name)
        write(root, f"model/model_{name.split('_')[0]}.pb", b"frozen graph " + name.encode())
    if coach is not None:
        write(root, "model/.coach_checkpoint", coach)
    if best is not None and last is not None:
        write(root, "model/deepracer_checkpoints.json", json.dumps(
            {"best_checkpoint": {"name": best, "avg_eval_metric": 58.9, "time_stamp": 5502.2},
             "last_checkpoint": {"name": last, "avg_eval_metric": 18.9, "time_stamp": 5734.3}}))
    write(root, "model_metadata.json" if metadata_at_root else "model/model_metadata.json", files.model_metadata)
    write(root, "ip/hyperparameters.json", files.hyperparameters)
    write(root, "training_params.yaml", files.training_params)
    write(root, "reward_function.py", files.reward_function)
    write(root, "metrics/TrainingMetrics.json", files.training_metrics)
    return root
