"""One place that turns a model's configuration into its network: clipped PPO's ActorCritic or SAC's SACNetworks.

Checkpoints, the trainer and the tools call `build_network` so no caller has to know which algorithm trained a model.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from racer.shared.policy.network_file import NetworkFile
from racer.shared.policy.networks import ActorCritic, PolicyConfig, policy_config_from_metadata
from racer.shared.policy.sac_networks import SACNetworks

if TYPE_CHECKING:
    from racer.shared.deepracer.model_metadata import ModelMetadata

__all__ = ["PolicyNetwork", "build_network", "build_network_for_metadata"]

PolicyNetwork = ActorCritic | SACNetworks


def build_network(config: PolicyConfig) -> PolicyNetwork:
    if config.training_algorithm == "sac":
        return SACNetworks(config)
    return ActorCritic(config)


def build_network_for_metadata(
    metadata: ModelMetadata, network: NetworkFile | None = None, stack_size: int = 1
) -> PolicyNetwork:
    """The freshly initialised network a model_metadata.json asks for (`network`: the custom files' network.json
    when model_metadata.json names one; `stack_size`: hyperparameters.json's)."""
    return build_network(policy_config_from_metadata(metadata, network, stack_size))
