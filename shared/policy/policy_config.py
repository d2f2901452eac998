"""What defines a network: `PolicyConfig` (frozen) -- `neural_network`, the inputs (`InputSpec`, sorted by name),
the action space and your own `network.json` if any -- derived from a parsed `model_metadata.json` by
`policy_config_from_metadata`, and round-tripped through JSON by `to_dict` / `from_dict` (checkpoints store it).
The modules it builds are in `networks.py`."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

from racer.shared.policy.layers import (
    LIDAR_EMBEDDER_DENSE,
    NETWORK_ARCHITECTURES,
    ConvLayer,
    DenseLayer,
)
from racer.shared.policy.network_file import NetworkFile, parse_network_file

if TYPE_CHECKING:
    from racer.shared.deepracer.model_metadata import ModelMetadata

IMAGE_HEIGHT_PX = 120
IMAGE_WIDTH_PX = 160
CAMERA_CHANNELS: dict[str, int] = {"FRONT_FACING_CAMERA": 1, "LEFT_CAMERA": 1, "observation": 1, "STEREO_CAMERAS": 2}
CONTINUOUS_MEAN = "linear"
"""The continuous head's mean function, recorded in every checkpoint manifest: DeepRacer's linear mean."""
LIDAR_SIZES: dict[str, int] = {"LIDAR": 64, "SECTOR_LIDAR": 8}
"""DISCRETIZED_SECTOR_LIDAR's size comes from `lidar_config` (num_sectors * num_values_per_sector)."""


@dataclass(frozen=True)
class InputSpec:
    name: str
    """DeepRacer sensor name, also the observation dict key."""
    kind: str
    """`camera` (shape (120, 160, C), raw 0-255) or `vector` (shape (n,), used as is)."""
    shape: tuple[int, ...]


@dataclass(frozen=True)
class PolicyConfig:
    """Everything that fixes the network's structure; stored with every checkpoint."""

    neural_network: str
    inputs: tuple[InputSpec, ...]
    """Sorted by name: RL Coach concatenates embedder outputs in sorted input-name order."""
    action_space_type: str
    """`discrete` or `continuous`."""
    num_actions: int
    """Number of discrete actions, or 2 (steering, speed) when continuous."""
    training_algorithm: str = "clipped_ppo"
    """`clipped_ppo` (ActorCritic here) or `sac` (racer.shared.policy.sac_networks.SACNetworks)."""
    network: NetworkFile | None = None
    """Your own network (network.json, racer.shared.policy.network_file) when `neural_network` names it; None for
    DeepRacer's three."""
    stack_size: int = 1
    """hyperparameters.json `stack_size`: camera inputs are the last N frames on the channel axis (their InputSpec
    shapes carry C * N channels; racer.shared.policy.frame_stack). LIDAR inputs are not stacked."""

    def __post_init__(self) -> None:
        if self.network is None and self.neural_network not in NETWORK_ARCHITECTURES:
            raise ValueError(
                f"unknown neural_network {self.neural_network!r} and no network file defines it; built-in: "
                f"{', '.join(NETWORK_ARCHITECTURES)}"
            )
        if self.network is not None and self.network.name != self.neural_network:
            raise ValueError(f"neural_network {self.neural_network!r} but the network file is {self.network.name!r}")
        if self.network is not None:
            names = {sensor for sensor, _ in self.network.input_embedders}
            missing = [spec.name for spec in self.inputs if spec.name not in names]
            if missing:
                raise ValueError(f"network {self.network.name!r} has no input_embedders for {', '.join(missing)}")
        if self.stack_size < 1:
            raise ValueError(f"stack_size must be at least 1, got {self.stack_size}")
        if self.action_space_type not in ("discrete", "continuous"):
            raise ValueError(f"action_space_type must be 'discrete' or 'continuous', got {self.action_space_type!r}")
        if self.action_space_type == "continuous" and self.num_actions != 2:
            raise ValueError(f"a continuous policy has 2 outputs (steering, speed), got {self.num_actions}")
        if self.num_actions < 1:
            raise ValueError(f"num_actions must be positive, got {self.num_actions}")
        if self.training_algorithm not in ("clipped_ppo", "sac"):
            raise ValueError(f"training_algorithm must be 'clipped_ppo' or 'sac', got {self.training_algorithm!r}")
        if self.training_algorithm == "sac" and not self.is_continuous:
            raise ValueError("SAC needs a continuous action space")
        names = [spec.name for spec in self.inputs]
        if not names or names != sorted(names) or len(set(names)) != len(names):
            raise ValueError(f"inputs must be non-empty, unique and sorted by name, got {names}")
        for spec in self.inputs:
            if spec.kind not in ("camera", "vector"):
                raise ValueError(f"input {spec.name!r}: kind must be 'camera' or 'vector', got {spec.kind!r}")

    @property
    def is_continuous(self) -> bool:
        return self.action_space_type == "continuous"

    def to_dict(self) -> dict:
        data = {
            "neural_network": self.neural_network,
            "inputs": [{"name": spec.name, "kind": spec.kind, "shape": list(spec.shape)} for spec in self.inputs],
            "action_space_type": self.action_space_type,
            "num_actions": self.num_actions,
            "training_algorithm": self.training_algorithm,
        }
        if self.network is not None:  # built-in networks' manifests stay as they were
            data["network"] = self.network.to_dict()
        if self.stack_size != 1:  # so do single-frame models' manifests
            data["stack_size"] = self.stack_size
        return data

    @classmethod
    def from_dict(cls, data: Mapping) -> PolicyConfig:
        return cls(
            neural_network=str(data["neural_network"]),
            inputs=tuple(
                InputSpec(name=str(item["name"]), kind=str(item["kind"]), shape=tuple(int(n) for n in item["shape"]))
                for item in data["inputs"]
            ),
            action_space_type=str(data["action_space_type"]),
            num_actions=int(data["num_actions"]),
            training_algorithm=str(data.get("training_algorithm", "clipped_ppo")),
            network=parse_network_file(data["network"], "policy_config.network") if data.get("network") else None,
            stack_size=int(data.get("stack_size", 1)),
        )

    def embedder_layers(self, spec: InputSpec) -> tuple[tuple[ConvLayer, ...], tuple[DenseLayer, ...]]:
        """(convs, dense layers) of one input's embedder."""
        if self.network is not None:
            layers = self.network.embedder(spec.name)
            convs = tuple(layer for layer in layers if isinstance(layer, ConvLayer))
            return convs, tuple(layer for layer in layers if isinstance(layer, DenseLayer))
        architecture = NETWORK_ARCHITECTURES[self.neural_network]
        if spec.kind == "vector":
            return (), LIDAR_EMBEDDER_DENSE
        if spec.name == "STEREO_CAMERAS":  # not by channels: a stacked mono camera has 2 * N of them
            return architecture.stereo_convs, architecture.stereo_dense
        return architecture.camera_convs, architecture.camera_dense

    @property
    def middleware_layers(self) -> tuple[DenseLayer, ...]:
        if self.network is not None:
            return self.network.middleware
        return NETWORK_ARCHITECTURES[self.neural_network].middleware_dense


def _input_spec(sensor: str, metadata: ModelMetadata, stack_size: int = 1) -> InputSpec:
    if sensor in CAMERA_CHANNELS:
        return InputSpec(sensor, "camera", (IMAGE_HEIGHT_PX, IMAGE_WIDTH_PX, CAMERA_CHANNELS[sensor] * stack_size))
    if sensor in LIDAR_SIZES:
        return InputSpec(sensor, "vector", (LIDAR_SIZES[sensor],))
    if sensor == "DISCRETIZED_SECTOR_LIDAR":
        lidar = metadata.lidar_config
        return InputSpec(sensor, "vector", (lidar.num_sectors * lidar.num_values_per_sector,))
    raise ValueError(f"sensor {sensor!r} has no network input (known: {', '.join([*CAMERA_CHANNELS, *LIDAR_SIZES])})")


def policy_config_from_metadata(
    metadata: ModelMetadata, network: NetworkFile | None = None, stack_size: int = 1
) -> PolicyConfig:
    """The network a parsed model_metadata.json asks for (clipped PPO or SAC); `network`: the custom files' network
    file when `neural_network` names one (racer.shared.policy.network_file.network_for_metadata); `stack_size`:
    hyperparameters.json's (camera inputs get that many frames)."""
    return PolicyConfig(
        neural_network=metadata.neural_network,
        inputs=tuple(_input_spec(sensor, metadata, stack_size) for sensor in sorted(metadata.sensors)),
        action_space_type=metadata.action_space_type,
        num_actions=metadata.num_actions,
        training_algorithm=metadata.training_algorithm,
        network=network,
        stack_size=stack_size,
    )
