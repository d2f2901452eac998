"""How far one PPO update in a reduced precision lands from the same update in fp32, on the same batch.

Used by `python -m benchmarks ppo` (it prints the figures) and by the guard test that keeps a faster precision from silently
changing what training learns. Both updates start from the same weights and shuffle the minibatches the same way,
so every difference comes from the arithmetic.
"""

from __future__ import annotations

import copy
import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass

import torch

from racer.shared.deepracer.hyperparameters import Hyperparameters
from racer.shared.episode import Episode
from racer.shared.policy.networks import ActorCritic
from racer.trainer.ppo import PPOLearner, PPOSettings, make_training_batch
from racer.trainer.precision import Precision

__all__ = ["UpdateAgreement", "update_agreement"]

_PROBABILITY_FLOOR = 1e-12


@dataclass(frozen=True)
class UpdateAgreement:
    precision: str
    update_kl: float
    """Mean KL(policy before || policy after) of the fp32 update: how far one update moves the policy."""
    precision_kl: float
    """Mean KL(fp32-updated policy || this precision's updated policy) over the batch's observations."""
    max_relative_gradient_difference: float
    """Over every parameter tensor, |g - g_fp32| / |g_fp32| of one minibatch's gradient at the starting weights."""
    gradient_difference_by_parameter: dict[str, float]

    @property
    def kl_share_of_update(self) -> float:
        """precision_kl / update_kl: 0 means the same update, 1 means a disagreement as large as the update itself."""
        return self.precision_kl / max(self.update_kl, _PROBABILITY_FLOOR)

    def to_dict(self) -> dict[str, object]:
        return {
            "precision": self.precision,
            "update_kl": round(self.update_kl, 6),
            "precision_kl": round(self.precision_kl, 7),
            "kl_share_of_update": round(self.kl_share_of_update, 4),
            "max_relative_gradient_difference": round(self.max_relative_gradient_difference, 4),
        }


def _probabilities(network: ActorCritic, observations: dict[str, torch.Tensor], chunk: int = 512) -> torch.Tensor:
    size = next(iter(observations.values())).shape[0]
    with torch.no_grad():
        parts = [
            network.distribution({name: array[start : start + chunk] for name, array in observations.items()}).probs
            for start in range(0, size, chunk)
        ]
    return torch.cat(parts).clamp_min(_PROBABILITY_FLOOR)


def _mean_kl(p: torch.Tensor, q: torch.Tensor) -> float:
    return float((p * (p.log() - q.log())).sum(dim=-1).mean())


def _updated(
    initial: ActorCritic, hp: Hyperparameters, episodes: Sequence[Episode], precision: Precision, seed: int
) -> ActorCritic:
    network = copy.deepcopy(initial)
    PPOLearner(network, hp, PPOSettings(seed=seed, threads_per_tower=1, precision=precision)).update(episodes)
    return network


def _gradients(
    initial: ActorCritic, hp: Hyperparameters, episodes: Sequence[Episode], precision: Precision, seed: int
) -> dict[str, torch.Tensor]:
    """One minibatch's gradient at the starting weights: a one-epoch update with learning rate 0 leaves the weights
    where they were and the last minibatch's gradient in .grad."""
    network = _updated(initial, dataclasses.replace(hp, lr=0.0, num_epochs=1), episodes, precision, seed)
    return {name: p.grad.clone() for name, p in network.named_parameters() if p.grad is not None}


def update_agreement(
    initial: ActorCritic,
    hyperparameters: Hyperparameters,
    episodes: Sequence[Episode],
    precision: Precision,
    seed: int = 0,
) -> UpdateAgreement:
    """Compare one whole PPO update (all epochs) and one minibatch gradient in `precision` against fp32."""
    if initial.config.is_continuous:
        raise ValueError("update_agreement compares categorical policies (a discrete action space)")
    observations = make_training_batch(episodes, initial.input_names).observations
    before = _probabilities(initial, observations)
    reference = _probabilities(_updated(initial, hyperparameters, episodes, Precision.FP32, seed), observations)
    candidate = _probabilities(_updated(initial, hyperparameters, episodes, precision, seed), observations)
    reference_gradients = _gradients(initial, hyperparameters, episodes, Precision.FP32, seed)
    candidate_gradients = _gradients(initial, hyperparameters, episodes, precision, seed)
    differences = {
        name: float((candidate_gradients[name] - g).norm() / g.norm().clamp_min(1e-20))
        for name, g in reference_gradients.items()
    }
    return UpdateAgreement(
        precision=precision.value,
        update_kl=_mean_kl(before, reference),
        precision_kl=_mean_kl(reference, candidate),
        max_relative_gradient_difference=max(differences.values()),
        gradient_difference_by_parameter=differences,
    )
