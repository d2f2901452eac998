"""The inference model racer writes beside each checkpoint (`model/model_<N>.onnx`, DeepRacer's `model_<N>.pb`).

Clipped PPO: one output `policy` (action probabilities, or the Gaussian mean, linear as DeepRacer's head). SAC: `policy` = tanh(mean),
the deterministic action evaluation and the car drive, then `policy_mean` and `policy_log_std` (before the squash),
which rollout workers sample from. Policy network only; critics stay out.
"""

from __future__ import annotations

import copy
import io
import warnings

import torch
from torch import nn

from racer.shared.policy.networks import ActorCritic
from racer.shared.policy.sac_networks import SACNetworks

ONNX_OPSET = 17
SAC_OUTPUTS = ("policy", "policy_mean", "policy_log_std")


class _InferenceModel(nn.Module):
    """Positional inputs in sorted sensor order -> the policy output, for the ONNX exporter."""

    def __init__(self, network: ActorCritic):
        super().__init__()
        self.network = network

    def forward(self, *inputs: torch.Tensor) -> torch.Tensor:
        return self.network.policy_output(dict(zip(self.network.input_names, inputs, strict=True)))


class _SacInferenceModel(nn.Module):
    """Positional inputs in sorted sensor order -> (tanh(mean), mean, log_std)."""

    def __init__(self, networks: SACNetworks):
        super().__init__()
        self.networks = networks

    def forward(self, *inputs: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        mean, log_std = self.networks.policy_distribution(dict(zip(self.networks.input_names, inputs, strict=True)))
        return torch.tanh(mean), mean, log_std


def export_onnx(network: ActorCritic | SACNetworks) -> bytes:
    """The inference model of a network: inputs named by sensor (raw 0-255 grayscale float [1, 120, 160, C],
    lidar [1, n]), outputs as the module docstring says. Policy tower only."""
    if next(network.parameters()).device.type != "cpu":  # a GPU trainer's network: export a host copy
        network = copy.deepcopy(network).cpu()
    sac = isinstance(network, SACNetworks)
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
                _SacInferenceModel(network) if sac else _InferenceModel(network),
                examples,
                buffer,
                input_names=list(network.input_names),
                output_names=list(SAC_OUTPUTS) if sac else ["policy"],
                opset_version=ONNX_OPSET,
                dynamo=False,
            )
    finally:
        network.train(was_training)
    return buffer.getvalue()
