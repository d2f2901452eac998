"""The torch modules of racer.shared.policy.layers' layer table: each layer with what RL Coach puts after it."""

from __future__ import annotations

from collections.abc import Sequence

from torch import nn

from racer.shared.policy.layers import ACTIVATIONS, ConvLayer, DenseLayer

__all__ = ["conv_modules", "dense_modules"]


def _after(layer: ConvLayer | DenseLayer, features: int, batchnorm: type[nn.Module]) -> list[nn.Module]:
    """RL Coach's BatchnormActivationDropout: batch-norm, then the activation, then dropout."""
    modules: list[nn.Module] = [batchnorm(features)] if layer.batchnorm else []
    if layer.activation == "relu":
        modules.append(nn.ReLU())
    elif layer.activation == "tanh":
        modules.append(nn.Tanh())
    elif layer.activation != "none":
        raise ValueError(f"activation must be one of {', '.join(ACTIVATIONS)}, got {layer.activation!r}")
    if layer.dropout > 0.0:
        modules.append(nn.Dropout(layer.dropout))
    return modules


def conv_modules(channels: int, convs: Sequence[ConvLayer]) -> nn.Sequential:
    """'valid' Conv2d layers with what follows each; DeepRacer's: [Conv2d, ReLU] * n."""
    modules: list[nn.Module] = []
    for conv in convs:
        modules.append(nn.Conv2d(channels, conv.filters, conv.kernel_px, conv.stride_px, padding=0))
        modules += _after(conv, conv.filters, nn.BatchNorm2d)
        channels = conv.filters
    return nn.Sequential(*modules)


def dense_modules(in_features: int, layers: Sequence[DenseLayer]) -> tuple[nn.Sequential, int]:
    """Dense layers with what follows each, and the output size; DeepRacer's: [Linear, ReLU] * n."""
    modules: list[nn.Module] = []
    for layer in layers:
        modules.append(nn.Linear(in_features, layer.units))
        modules += _after(layer, layer.units, nn.BatchNorm1d)
        in_features = layer.units
    return nn.Sequential(*modules), in_features
