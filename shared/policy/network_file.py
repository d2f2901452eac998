"""Your own network: `network.json` in the custom files, in RL Coach's terms (a preset's `input_embedders_parameters`
and `middleware_parameters`).

    {
      "name": "WIDE_MIDDLEWARE",
      "input_embedders": {
        "FRONT_FACING_CAMERA": [
          {"type": "Conv2d", "num_filters": 32, "kernel_size": 8, "strides": 4},
          {"type": "Conv2d", "num_filters": 64, "kernel_size": 4, "strides": 2, "batchnorm": true},
          {"type": "Dense", "units": 256, "activation": "tanh", "dropout": 0.1}
        ]
      },
      "middleware": [{"type": "Dense", "units": 1024}]
    }

Each sensor of model_metadata.json needs its embedder: a camera's is one or more Conv2d layers then any Dense layers
(flattened in (H, W, C) order between them), a LIDAR's one or more Dense layers. `middleware` is Dense layers after
the embedders' outputs are concatenated (sorted by sensor name). Every layer may carry `activation` (`relu`, the
default, `tanh` or `none`), `batchnorm` (false) and `dropout` (a rate, 0). model_metadata.json names the network by
its `name` in `neural_network`.

Public API: `NetworkFile` (frozen; `to_dict()`), `parse_network_file(data, source)`, `load_network_file(path)`,
`network_for_metadata(folder, metadata)` (the custom files' network, checked against model_metadata.json),
`network_difference(a, b)`, `NetworkFileError`. The size check is racer.shared.policy.network_size.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from racer.shared.deepracer.model_metadata import NEURAL_NETWORKS
from racer.shared.policy.layers import ACTIVATIONS, ConvLayer, DenseLayer

if TYPE_CHECKING:
    from racer.shared.deepracer.model_metadata import ModelMetadata

__all__ = [
    "NETWORK_FILE",
    "NetworkFile",
    "NetworkFileError",
    "load_network_file",
    "network_difference",
    "network_for_metadata",
    "parse_network_file",
]

NETWORK_FILE = "network.json"
CAMERA_SENSORS = ("FRONT_FACING_CAMERA", "LEFT_CAMERA", "STEREO_CAMERAS", "observation")
VECTOR_SENSORS = ("LIDAR", "SECTOR_LIDAR", "DISCRETIZED_SECTOR_LIDAR")
_LAYER_KEYS = {
    "Conv2d": ("type", "num_filters", "kernel_size", "strides", "activation", "batchnorm", "dropout"),
    "Dense": ("type", "units", "activation", "batchnorm", "dropout"),
}


class NetworkFileError(ValueError):
    """A network file racer cannot build; the message names the file, the layer and the field."""


Layer = ConvLayer | DenseLayer


@dataclass(frozen=True)
class NetworkFile:
    name: str
    input_embedders: tuple[tuple[str, tuple[Layer, ...]], ...]
    """(sensor, layers), sorted by sensor."""
    middleware: tuple[DenseLayer, ...]

    def embedder(self, sensor: str) -> tuple[Layer, ...]:
        for name, layers in self.input_embedders:
            if name == sensor:
                return layers
        raise KeyError(f"network {self.name!r} has no input_embedders.{sensor}")

    def to_dict(self) -> dict:
        return {
            "name": self.name,
            "input_embedders": {
                sensor: [_layer_dict(layer) for layer in layers] for sensor, layers in self.input_embedders
            },
            "middleware": [_layer_dict(layer) for layer in self.middleware],
        }


def _layer_dict(layer: Layer) -> dict:
    if isinstance(layer, ConvLayer):
        data: dict = {"type": "Conv2d", "num_filters": layer.filters, "kernel_size": layer.kernel_px}
        data["strides"] = layer.stride_px
    else:
        data = {"type": "Dense", "units": layer.units}
    return {**data, "activation": layer.activation, "batchnorm": layer.batchnorm, "dropout": layer.dropout}


class _Where:
    def __init__(self, source: str):
        self.source = source

    def error(self, where: str, problem: str) -> NetworkFileError:
        return NetworkFileError(f"{self.source}: {where}: {problem}")


def _positive_int(check: _Where, where: str, data: Mapping, key: str) -> int:
    if key not in data:
        raise check.error(where, f"{key}: missing")
    value = data[key]
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise check.error(where, f"{key}: {value!r} is not a positive integer")
    return value


def _parse_layer(check: _Where, where: str, data: object) -> Layer:
    if not isinstance(data, dict):
        raise check.error(where, f"expected a layer object such as {{'type': 'Dense', 'units': 64}}, got {data!r}")
    kind = data.get("type")
    if kind not in _LAYER_KEYS:
        raise check.error(where, f"type: {kind!r} is not a layer type; allowed: Conv2d, Dense")
    unknown = sorted(set(data) - set(_LAYER_KEYS[kind]))
    if unknown:
        raise check.error(where, f"{', '.join(unknown)}: not a {kind} field; allowed: {', '.join(_LAYER_KEYS[kind])}")
    activation = data.get("activation", "relu")
    if activation not in ACTIVATIONS:
        raise check.error(where, f"activation: {activation!r} is not allowed; allowed: {', '.join(ACTIVATIONS)}")
    batchnorm = data.get("batchnorm", False)
    if not isinstance(batchnorm, bool):
        raise check.error(where, f"batchnorm: {batchnorm!r} is not true or false")
    dropout = data.get("dropout", 0.0)
    if isinstance(dropout, bool) or not isinstance(dropout, int | float) or not 0.0 <= dropout < 1.0:
        raise check.error(where, f"dropout: {dropout!r} is not a rate in [0, 1)")
    options = {"activation": activation, "batchnorm": batchnorm, "dropout": float(dropout)}
    if kind == "Dense":
        return DenseLayer(_positive_int(check, where, data, "units"), **options)
    filters = _positive_int(check, where, data, "num_filters")
    kernel = _positive_int(check, where, data, "kernel_size")
    return ConvLayer(filters, kernel, _positive_int(check, where, data, "strides"), **options)


def _parse_scheme(check: _Where, where: str, data: object, camera: bool | None) -> tuple[Layer, ...]:
    """`camera` True: Conv2d layers (at least one) then Dense; False: Dense (at least one); None: Dense (any)."""
    if not isinstance(data, list):
        raise check.error(where, f"expected a list of layers, got {data!r}")
    layers = tuple(_parse_layer(check, f"{where}[{index}]", item) for index, item in enumerate(data))
    seen_dense = False
    for index, layer in enumerate(layers):
        if isinstance(layer, ConvLayer) and (camera is not True or seen_dense):
            reason = "a camera's Conv2d layers come before its Dense layers" if camera else "only Dense layers here"
            raise check.error(f"{where}[{index}]", f"type: Conv2d is not allowed: {reason}")
        seen_dense = seen_dense or isinstance(layer, DenseLayer)
    if camera is True and not (layers and isinstance(layers[0], ConvLayer)):
        raise check.error(where, "a camera's embedder starts with at least one Conv2d layer")
    if camera is False and not layers:
        raise check.error(where, "a LIDAR's embedder needs at least one Dense layer")
    return layers


def parse_network_file(data: object, source: str = NETWORK_FILE) -> NetworkFile:
    """Validate a parsed network.json; errors name `source`, the layer (`input_embedders.LIDAR[1]`) and the field."""
    check = _Where(source)
    if not isinstance(data, dict):
        raise check.error("(top level)", "expected a JSON object with name, input_embedders and middleware")
    unknown = sorted(set(data) - {"name", "input_embedders", "middleware"})
    if unknown:
        raise check.error(", ".join(unknown), "not a network file field; allowed: name, input_embedders, middleware")
    name = data.get("name")
    if not isinstance(name, str) or not name.strip() or len(name) > 64 or not name.isprintable():
        raise check.error("name", f"{name!r} is not a name (a non-empty string of up to 64 characters)")
    if name in NEURAL_NETWORKS:
        raise check.error("name", f"{name!r} is one of DeepRacer's built-in networks; give yours its own name")
    embedders = data.get("input_embedders")
    if not isinstance(embedders, dict) or not embedders:
        raise check.error("input_embedders", "expected an object: sensor name -> list of layers")
    parsed = []
    for sensor in sorted(embedders):
        if sensor not in CAMERA_SENSORS + VECTOR_SENSORS:
            known = ", ".join(CAMERA_SENSORS + VECTOR_SENSORS)
            raise check.error(f"input_embedders.{sensor}", f"not a DeepRacer sensor; known: {known}")
        scheme = _parse_scheme(check, f"input_embedders.{sensor}", embedders[sensor], sensor in CAMERA_SENSORS)
        parsed.append((sensor, scheme))
    middleware = _parse_scheme(check, "middleware", data.get("middleware", []), None)
    return NetworkFile(name=name, input_embedders=tuple(parsed), middleware=middleware)  # type: ignore[arg-type]


def load_network_file(path: str | Path) -> NetworkFile:
    path = Path(path)
    try:
        data = json.loads(path.read_text(encoding="utf-8-sig"))
    except json.JSONDecodeError as error:
        raise NetworkFileError(
            f"{path}: invalid JSON at line {error.lineno}, column {error.colno}: {error.msg}"
        ) from error
    except OSError as error:
        raise NetworkFileError(f"{path}: cannot read it: {error}") from error
    return parse_network_file(data, source=str(path))


def network_for_metadata(folder: str | Path, metadata: ModelMetadata) -> NetworkFile | None:
    """The custom files' network for `metadata`: None for DeepRacer's three networks; else folder/network.json,
    which must exist, carry model_metadata.json's `neural_network` as its name and embed every sensor."""
    folder = Path(folder)
    path, metadata_path = folder / NETWORK_FILE, folder / "model_metadata.json"
    if metadata.neural_network in NEURAL_NETWORKS:
        return None
    if not path.is_file():
        raise NetworkFileError(
            f"{metadata_path}: neural_network: {metadata.neural_network!r} is not one of DeepRacer's networks "
            f"({', '.join(NEURAL_NETWORKS)}) and there is no {path} to define it; fix: add {NETWORK_FILE} with "
            f'"name": {json.dumps(metadata.neural_network)}, or name a built-in network'
        )
    network = load_network_file(path)
    if network.name != metadata.neural_network:
        raise NetworkFileError(
            f"{metadata_path}: neural_network: {metadata.neural_network!r} does not match {path}: name: "
            f"{network.name!r}; fix: use the same name in both files"
        )
    names = {sensor for sensor, _ in network.input_embedders}
    missing = [sensor for sensor in metadata.sensors if sensor not in names]
    if missing:
        raise NetworkFileError(
            f"{path}: input_embedders: no embedder for {', '.join(missing)} (a sensor of {metadata_path}); "
            f"fix: add input_embedders.{missing[0]}"
        )
    return network


def network_difference(ours: Mapping | None, theirs: Mapping | None, where: str = "") -> str | None:
    """The first difference between two networks' `to_dict()` forms, as `middleware[0].units: 512 vs 1024`."""
    if isinstance(ours, Mapping) and isinstance(theirs, Mapping):
        for key in sorted(set(ours) | set(theirs), key=str):
            found = network_difference(ours.get(key), theirs.get(key), f"{where}.{key}" if where else str(key))
            if found:
                return found
        return None
    if isinstance(ours, list) and isinstance(theirs, list):
        if len(ours) != len(theirs):
            return f"{where}: {len(ours)} layers vs {len(theirs)}"
        for index, (a, b) in enumerate(zip(ours, theirs, strict=True)):
            found = network_difference(a, b, f"{where}[{index}]")
            if found:
                return found
        return None
    return None if ours == theirs else f"{where or '(network)'}: {ours!r} vs {theirs!r}"
