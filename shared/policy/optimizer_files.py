"""An optimiser's state as safetensors tensors plus JSON scalars, keyed by parameter name (no pickle), and back."""

from __future__ import annotations

from collections.abc import Mapping

import torch
from torch import nn

from racer.shared.policy.manifest import CheckpointError


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
