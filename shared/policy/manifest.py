"""The manifest racer writes last for each checkpoint (`model/<N>_Step-<M>.ckpt.json`): what produced the
checkpoint and the size and sha256 of each of its files, so a reader can tell a complete checkpoint from a
half-written or replaced one. Reading one needs no torch (the rollout and evaluation workers have none)."""

from __future__ import annotations

import hashlib
import platform
from collections.abc import Mapping
from dataclasses import dataclass
from importlib import metadata as package_metadata

from racer.shared.policy.policy_config import CONTINUOUS_MEAN, PolicyConfig

FORMAT = "racer-checkpoint-1"


class CheckpointError(Exception):
    """A checkpoint that is missing, incomplete or corrupt; the message names the key."""


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
            "continuous_mean": CONTINUOUS_MEAN,
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
        continuous = data.get("policy_config", {}).get("action_space_type") == "continuous"
        if continuous and data.get("continuous_mean") != CONTINUOUS_MEAN:
            raise CheckpointError(
                f"checkpoint {data.get('name')} is a continuous model whose manifest lacks continuous_mean "
                f"{CONTINUOUS_MEAN!r} (its mean is tanh of the layer's output, DeepRacer's is the output itself): the "
                "same weights would drive differently, so racer refuses it. Train it again, or evaluate it with the "
                "racer version that trained it"
            )
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


def sha256_hex(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def package_versions() -> dict[str, str]:
    """What saved a checkpoint (the trainer, which has torch: imported here, not at module level, so that reading a
    manifest needs no torch)."""
    import torch

    versions = {"python": platform.python_version(), "torch": torch.__version__}
    # key: distribution (racer's distribution is racer-deepracer: PyPI's `racer` is another project)
    for key, distribution in (("racer", "racer-deepracer"), ("safetensors", "safetensors"), ("onnx", "onnx")):
        try:
            versions[key] = package_metadata.version(distribution)
        except package_metadata.PackageNotFoundError:
            versions[key] = "unknown"
    return versions
