"""The one factory of learners: model_metadata.json's `training_algorithm` picks clipped PPO or SAC, and the network
it trains (racer.shared.policy.factory)."""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass

from racer.shared.deepracer.hyperparameters import Hyperparameters
from racer.shared.deepracer.model_metadata import ModelMetadata
from racer.shared.policy.factory import build_network_for_metadata
from racer.shared.policy.network_file import NetworkFile
from racer.trainer.learner import Learner
from racer.trainer.ppo import PPOLearner, PPOSettings
from racer.trainer.precision import DEFAULT_PRECISION, Precision
from racer.trainer.preset import Preset, sac_updates_per_transition
from racer.trainer.sac import SACLearner, SACSettings

__all__ = ["LEARNERS", "LearnerOptions", "build_learner"]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class LearnerOptions:
    """The trainer's own knobs of a learner (not hyperparameters)."""

    seed: int | None = None
    precision: Precision = DEFAULT_PRECISION
    device: str = "cpu"
    """The torch device the learner trains on (racer.trainer.device)."""
    sac_replay_memory_mb: float = 1024.0
    """SAC: memory budget of the replay ring (its capacity in transitions follows from it)."""
    sac_updates_per_transition: float | None = None
    """SAC: gradient steps per transition received, from the command line; None: the preset's
    `updates_per_transition`, else DeepRacer's 1 (both given and different is refused)."""
    network: NetworkFile | None = None
    """The custom files' network.json when model_metadata.json names it (racer.shared.policy.network_file)."""
    preset: Preset | None = None
    """The custom files' preset.json (racer.trainer.preset); None: DeepRacer's settings."""


def _clipped_ppo(metadata: ModelMetadata, hyperparameters: Hyperparameters, options: LearnerOptions) -> Learner:
    network = build_network_for_metadata(metadata, options.network, hyperparameters.stack_size)
    settings = PPOSettings(seed=options.seed, precision=options.precision, device=options.device)
    if options.preset is not None:
        settings = options.preset.ppo_settings(settings)
    return PPOLearner(network, hyperparameters, settings)


def _sac(metadata: ModelMetadata, hyperparameters: Hyperparameters, options: LearnerOptions) -> Learner:
    settings = SACSettings(
        replay_memory_bytes=int(options.sac_replay_memory_mb * 2**20),
        updates_per_transition=sac_updates_per_transition(options.sac_updates_per_transition, options.preset),
        seed=options.seed,
        precision=options.precision,
        device=options.device,
    )
    if options.preset is not None:
        settings = options.preset.sac_settings(settings)
    learner = SACLearner(
        build_network_for_metadata(metadata, options.network, hyperparameters.stack_size), hyperparameters, settings
    )
    log.info("SAC replay memory: %d transitions in %.0f MB", learner.replay.capacity, options.sac_replay_memory_mb)
    return learner


LEARNERS: dict[str, Callable[[ModelMetadata, Hyperparameters, LearnerOptions], Learner]] = {
    "clipped_ppo": _clipped_ppo,
    "sac": _sac,
}
"""model_metadata.json's training_algorithm -> the learner that trains it."""


def build_learner(metadata: ModelMetadata, hyperparameters: Hyperparameters, options: LearnerOptions) -> Learner:
    """A fresh network for `metadata` and the learner of its training algorithm."""
    return LEARNERS[metadata.training_algorithm](metadata, hyperparameters, options)
