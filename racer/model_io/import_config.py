"""The racer network a DeepRacer-format import fills: model_metadata.json, plus your own network (network.json) and
the frame stack (hyperparameters.json `stack_size`) when the model has them.

A TensorFlow checkpoint or frozen graph holds weights, not the network's recipe: racer's import builds the network
first and loads the graph's tensors into it, so a model with your own network or stacked frames imports only with the
files that say so. racer's export carries both (`model/network.json`, `ip/hyperparameters.json`); the car's
`model.tar.gz` has neither (DeepRacer's car format holds model_metadata.json and the graph only), so such a model
is imported from the export folder, not from the car tarball.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Collection

from racer.model_io.tensorflow.errors import UnsupportedGraphError
from racer.shared import model_layout
from racer.shared.deepracer.model_metadata import NEURAL_NETWORKS, ModelMetadata
from racer.shared.policy.network_file import NETWORK_FILE, NetworkFileError, parse_network_file
from racer.shared.policy.policy_config import PolicyConfig, policy_config_from_metadata

__all__ = ["NETWORK_KEYS", "imported_policy_config"]

NETWORK_KEYS = (model_layout.NETWORK, NETWORK_FILE)
"""racer's store layout first, then the folder's root."""
HYPERPARAMETER_KEYS = (model_layout.HYPERPARAMETERS, "hyperparameters.json")


def imported_policy_config(
    metadata: ModelMetadata, files: Collection[str], read: Callable[[str], bytes], where: str
) -> PolicyConfig:
    """The PolicyConfig for `metadata`, with the model's network.json and stack_size (`files`: the keys there are,
    `read`: their bytes, `where`: how to name the model in errors). UnsupportedGraphError says what is missing."""
    network = None
    if metadata.neural_network not in NEURAL_NETWORKS:
        key = next((key for key in NETWORK_KEYS if key in files), None)
        if key is None:
            raise UnsupportedGraphError(
                f"{where}: model_metadata.json's neural_network {metadata.neural_network!r} is your own network, and "
                f"there is no {' or '.join(NETWORK_KEYS)} to say its layers (the car's model.tar.gz has none: import "
                "the folder `racer model export` wrote)"
            )
        try:
            network = parse_network_file(json.loads(read(key).decode("utf-8-sig")), f"{where}/{key}")
        except (NetworkFileError, ValueError) as error:
            raise UnsupportedGraphError(str(error)) from None
    try:
        return policy_config_from_metadata(metadata, network, _stack_size(files, read, where))
    except ValueError as error:
        raise UnsupportedGraphError(f"{where}/model_metadata.json: {error}") from None


def _stack_size(files: Collection[str], read: Callable[[str], bytes], where: str) -> int:
    """hyperparameters.json's stack_size; 1 (DeepRacer's) without the file or the key."""
    key = next((key for key in HYPERPARAMETER_KEYS if key in files), None)
    if key is None:
        return 1
    try:
        data = json.loads(read(key).decode("utf-8-sig"))
    except ValueError as error:
        raise UnsupportedGraphError(f"{where}/{key}: not JSON ({error})") from None
    value = data.get("stack_size", 1) if isinstance(data, dict) else 1
    if isinstance(value, bool) or not isinstance(value, int | float) or int(value) != value or not 1 <= value <= 8:
        raise UnsupportedGraphError(f"{where}/{key}: stack_size {value!r} is not an integer from 1 to 8")
    return int(value)
