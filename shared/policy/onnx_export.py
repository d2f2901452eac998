"""The inference model racer writes beside each checkpoint (`model/model_<N>.onnx`, DeepRacer's `model_<N>.pb`)."""

from __future__ import annotations

import io
import warnings

import torch
from torch import nn

from racer.shared.policy.networks import ActorCritic

ONNX_OPSET = 17


class _InferenceModel(nn.Module):
    """Positional inputs in sorted sensor order -> the policy output, for the ONNX exporter."""

    def __init__(self, network: ActorCritic):
        super().__init__()
        self.network = network

    def forward(self, *inputs: torch.Tensor) -> torch.Tensor:
        return self.network.policy_output(dict(zip(self.network.input_names, inputs, strict=True)))


def export_onnx(network: ActorCritic) -> bytes:
    """The inference model of a network: inputs named by sensor (raw 0-255 grayscale float [1, 120, 160, C],
    lidar [1, n]), output `policy` = action probabilities or the Gaussian mean (linear, as DeepRacer). Policy tower only."""
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
