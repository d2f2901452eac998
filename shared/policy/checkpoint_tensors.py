"""The torch side of racer's checkpoints (racer.shared.policy.checkpoints): network weights and optimiser state to and
from safetensors bytes, the network a checkpoint's PolicyConfig builds, and its ONNX export.

`CheckpointStore` imports this module only in the methods that need torch (`load`, `restore`, `load_policy`, `save`),
so what the rollout and evaluation workers do with a checkpoint -- its manifest, its ONNX model and a continuous
policy's log-std, read with safetensors' numpy API -- imports no torch, and their image carries none.
"""

from __future__ import annotations

from collections.abc import Mapping

import torch
from safetensors.torch import load as load_safetensors
from safetensors.torch import save as save_safetensors

from racer.shared.policy.factory import PolicyNetwork, build_network
from racer.shared.policy.onnx_export import export_onnx
from racer.shared.policy.optimizer_files import (
    load_optimizer_state,
    optimizer_state_from_files,
    optimizer_state_to_files,
)

__all__ = [
    "PolicyNetwork",
    "build_network",
    "export_onnx",
    "load_optimizer_state",
    "optimizer_state_from_files",
    "optimizer_state_to_files",
    "tensors_from_bytes",
    "tensors_to_bytes",
]


def tensors_to_bytes(tensors: Mapping[str, torch.Tensor]) -> bytes:
    """safetensors bytes of a state dict (no pickle anywhere), from host copies when the trainer runs on a GPU."""
    return save_safetensors({name: tensor.detach().cpu().contiguous() for name, tensor in tensors.items()})


def tensors_from_bytes(data: bytes) -> dict[str, torch.Tensor]:
    """A state dict from safetensors bytes."""
    return load_safetensors(data)
