"""One embedder's or middleware's layers as RL Coach names them, for any racer network (DeepRacer's three or your
own network.json), as plain data for the graph builder (coach_graph.py) and the variable table (coach_layout.py).

RL Coach builds a layer list where every layer is followed by a `BatchnormActivationDropout` entry, so the n-th layer
of a scheme (0-based) has the scope `Conv2d_<2n>` or `Dense_<2n>`, and what follows it is named after
`BatchnormActivationDropout_<2n+1>`: its batch-norm variables live under `..._<2n+1>_batchnorm/` (`gamma`, `beta`,
`moving_mean`, `moving_variance`, as `tf.layers.batch_normalization` names them) and its activation node is
`..._<2n+1>_activation`. A camera embedder's dense layers go on counting after its convolutions (`Dense_6` after three
convolutions). Dropout is the identity at inference, so the frozen graph has no node for it.

racer's torch modules (racer.shared.policy.layer_modules) put the same steps in one `nn.Sequential` per part (`convs`,
`dense`, `middleware`): layer, [batch-norm], [activation], [dropout]. `racer` below is each module's state_dict path,
counted the same way, so every RL Coach variable maps onto exactly one racer tensor.
"""

from __future__ import annotations

from collections.abc import Sequence

from racer.shared.policy.layers import ConvLayer, DenseLayer

__all__ = ["BATCHNORM_EPSILON", "BATCHNORM_VARIABLES", "coach_layers"]

BATCHNORM_EPSILON = 1e-5
"""torch's BatchNorm default, which racer trains with (RL Coach's TensorFlow default is 1e-3): the graph computes
racer's function, so it carries racer's epsilon."""
BATCHNORM_VARIABLES = (
    ("gamma", "weight"),
    ("beta", "bias"),
    ("moving_mean", "running_mean"),
    ("moving_variance", "running_var"),
)
"""RL Coach's (tf.layers) batch-norm variable -> racer's BatchNorm state_dict entry, in inference's order."""


def coach_layers(
    layers: Sequence[ConvLayer | DenseLayer], racer_part: str, in_shape: tuple[int, ...], first_index: int = 0
) -> tuple[list[dict], tuple[int, ...]]:
    """RL Coach's description of `layers` (one racer `nn.Sequential` named `racer_part`), and the output shape.

    `in_shape`: (height, width, channels) of the image for convolutions, (features,) for dense layers; a dense layer
    after convolutions reads them flattened in (H, W, C) order. `first_index`: the scheme position of the first layer
    (a camera embedder's dense layers continue its convolutions' count)."""
    described = []
    module = 0
    shape = tuple(in_shape)
    for offset, layer in enumerate(layers):
        position = 2 * (first_index + offset)
        after = f"BatchnormActivationDropout_{position + 1}"
        entry: dict = {"racer": f"{racer_part}.{module}", "activation": layer.activation, "after": after}
        if isinstance(layer, ConvLayer):
            height = (shape[0] - layer.kernel_px) // layer.stride_px + 1
            width = (shape[1] - layer.kernel_px) // layer.stride_px + 1
            entry.update(
                type="conv",
                scope=f"Conv2d_{position}",
                kernel=[layer.kernel_px, layer.kernel_px, shape[2], layer.filters],
                stride=layer.stride_px,
            )
            shape = (height, width, layer.filters)
            units = layer.filters
        else:
            features = 1
            for size in shape:
                features *= size
            entry.update(type="dense", scope=f"Dense_{position}", kernel=[features, layer.units])
            shape = (layer.units,)
            units = layer.units
        module += 1
        if layer.batchnorm:
            entry["batchnorm"] = {
                "scope": f"{after}_batchnorm",
                "racer": f"{racer_part}.{module}",
                "units": units,
                "epsilon": BATCHNORM_EPSILON,
            }
            module += 1
        module += 1 if layer.activation != "none" else 0
        module += 1 if layer.dropout > 0.0 else 0
        described.append(entry)
    return described, shape
