"""The layer table of racer's networks: DeepRacer's three built-in networks (`NETWORK_ARCHITECTURES`) and the layer
types a network file (racer.shared.policy.network_file) may use, in RL Coach's terms.

A layer is a `ConvLayer` (RL Coach's `Conv2d(num_filters, kernel_size, strides)`, 'valid' padding) or a `DenseLayer`
(`Dense(units)`), each followed, as RL Coach's `BatchnormActivationDropout` does, by an optional batch-norm, its
activation (`relu`, `tanh` or `none`) and an optional dropout. DeepRacer's built-in networks use ReLU after every layer
and neither batch-norm nor dropout (RL Coach's SCHEME embedders ignore those entries of DeepRacer's scheme dicts), so
their layers are the defaults and build exactly the modules racer always built.

This table needs no torch (a worker reads a checkpoint's PolicyConfig without it); the torch modules built from it are
in racer.shared.policy.layer_modules.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

__all__ = [
    "ACTIVATIONS",
    "LIDAR_EMBEDDER_DENSE",
    "NETWORK_ARCHITECTURES",
    "ConvLayer",
    "DenseLayer",
    "NetworkArchitecture",
    "conv_output_shape",
]

ACTIVATIONS = ("relu", "tanh", "none")
"""RL Coach's activation_function values a network file may use (`none`: linear)."""


@dataclass(frozen=True)
class ConvLayer:
    filters: int
    kernel_px: int
    stride_px: int
    activation: str = "relu"
    batchnorm: bool = False
    dropout: float = 0.0
    """Dropout rate in [0, 1): the fraction of outputs zeroed while training (none when evaluating or racing)."""


@dataclass(frozen=True)
class DenseLayer:
    units: int
    activation: str = "relu"
    batchnorm: bool = False
    dropout: float = 0.0


LIDAR_EMBEDDER_DENSE = (DenseLayer(256), DenseLayer(256))
"""All three LIDAR-type sensors use the same dense embedder, whatever the built-in network."""


@dataclass(frozen=True)
class NetworkArchitecture:
    """One built-in `neural_network` value of model_metadata.json: its embedders and middleware."""

    camera_convs: tuple[ConvLayer, ...]
    stereo_convs: tuple[ConvLayer, ...]
    camera_dense: tuple[DenseLayer, ...]
    """Dense layers after the camera convs (also used after the stereo convs only when the stereo table says so)."""
    stereo_dense: tuple[DenseLayer, ...]
    middleware_dense: tuple[DenseLayer, ...]


def _dense(*units: int) -> tuple[DenseLayer, ...]:
    return tuple(DenseLayer(n) for n in units)


_SHALLOW_CONVS = (ConvLayer(32, 8, 4), ConvLayer(64, 4, 2), ConvLayer(64, 3, 1))
_DEEP_STEREO_CONVS = (
    ConvLayer(32, 3, 1),
    ConvLayer(64, 3, 2),
    ConvLayer(64, 3, 1),
    ConvLayer(128, 3, 2),
    ConvLayer(128, 3, 1),
)

NETWORK_ARCHITECTURES: dict[str, NetworkArchitecture] = {
    "DEEP_CONVOLUTIONAL_NETWORK_SHALLOW": NetworkArchitecture(
        camera_convs=_SHALLOW_CONVS,
        stereo_convs=_SHALLOW_CONVS,
        camera_dense=(),
        stereo_dense=(),
        middleware_dense=_dense(512),
    ),
    "DEEP_CONVOLUTIONAL_NETWORK": NetworkArchitecture(
        camera_convs=(ConvLayer(32, 5, 2), ConvLayer(32, 3, 1), ConvLayer(64, 3, 2), ConvLayer(64, 3, 1)),
        stereo_convs=_DEEP_STEREO_CONVS,
        camera_dense=_dense(64),
        stereo_dense=(),
        middleware_dense=_dense(512),
    ),
    "DEEP_CONVOLUTIONAL_NETWORK_DEEP": NetworkArchitecture(
        camera_convs=(ConvLayer(32, 8, 4), ConvLayer(32, 4, 2), ConvLayer(64, 4, 2), ConvLayer(64, 3, 1)),
        stereo_convs=_DEEP_STEREO_CONVS,
        camera_dense=_dense(512, 512),
        stereo_dense=(),
        middleware_dense=_dense(256, 128),
    ),
}
"""Reference section 8.2 (sensors/utils.py embedders, custom_architectures.py middleware)."""


def conv_output_shape(height_px: int, width_px: int, convs: Sequence[ConvLayer]) -> tuple[int, int, int]:
    """(height, width, channels) after 'valid' convolutions: out = floor((in - kernel) / stride) + 1."""
    channels = 0
    for conv in convs:
        height_px = (height_px - conv.kernel_px) // conv.stride_px + 1
        width_px = (width_px - conv.kernel_px) // conv.stride_px + 1
        channels = conv.filters
        if height_px < 1 or width_px < 1:
            raise ValueError(f"convolution {conv} leaves no pixels")
    return height_px, width_px, channels
