"""DeepRacer's clipped PPO update, top to bottom (deepracer-simapp v5.3.3 `bundle/markov/sagemaker_graph_manager.py`
`get_clipped_ppo_params`, with RL Coach's clipped PPO agent vendored there).

Public API
----------
    learner = PPOLearner(network, hyperparameters)          # one Adam over both towers
    stats = learner.update(episodes)                        # list[EpochStats], one per epoch
    for line in learner.training_lines(stats): print(line)  # DeepRacer's "Policy training> ..." lines
    learner.learning_rate, learner.optimizer                # for checkpoints and logs

`racer.trainer.log_lines` formats DeepRacer's per-episode "Training> Name=main_level/agent, ..." line.

One update, as DeepRacer's `ClippedPPOAgent.train()` does it:

1. The iteration's transitions (all episodes, laid end to end) become one batch.
2. The *old policy* is the network as it is now, frozen: DeepRacer syncs a target copy at the start of `train()`
   and recomputes the old probabilities per minibatch from it. The copy never changes during the update, so we
   evaluate it once for every transition before the first step -- the same numbers, one forward pass per
   transition instead of one per epoch. The same pass gives V(s) for GAE.
3. GAE (lambda 0.95, value 0 after every episode's last transition) gives advantages and value targets;
   advantages are standardised over the whole iteration: (A - mean) / (std + 1e-8).
4. `num_epochs` times: shuffle, cut into minibatches of `batch_size` (remainder dropped; when the iteration has
   at most `batch_size` transitions the minibatch shrinks to the largest power of two that fits), and per minibatch
       ratio     = exp(log pi(a|s) - log pi_old(a|s))
       surrogate = -mean(min(ratio * A, clip(ratio, 0.8, 1.2) * A))
       value     = mean((V(s) - target)^2)  or Huber(delta=1), per `loss_type`
       loss      = value + surrogate - beta_entropy * mean(entropy)
   then one Adam step (lr = `lr`, betas 0.9/0.999, eps 1e-5) on both towers. No gradient clipping, no KL penalty,
   no value clipping. A preset (racer.trainer.preset) may change these; its `clipping_decay_schedule` scales the
   0.2 by the run's environment steps (racer.trainer.clip_schedule).

Speed (see `python -m benchmarks ppo`): the value tower's forward and backward run on a second thread while the policy
tower runs on the calling one (the towers share no weight, so the gradients are exactly those of the summed loss),
each with `threads_per_tower` intra-op threads for the duration of the update; Adam runs as one fused kernel
(`fused=True`, same arithmetic as the textbook loop); the network is channels-last; step 2 replaces the
per-minibatch old-policy pass. The towers compute in fp32 on every CPU; `PPOSettings.precision` = bf16 runs them
under bf16 autocast (faster where the CPU has native bf16, far slower where it is emulated; docs/benchmarks.md),
which changes what a run learns (`racer.trainer.precision`). torch.compile is not used: it is slower than eager here.

Non-finite numbers never abort training (`racer.trainer.nan_guard`): a NaN/inf loss, gradient or weight rolls the
network and optimiser back to their state before the update, halves the learning rate, logs one plain warning and
retries the update (up to `PPOSettings.max_nan_retries` times, then the iteration's data is skipped).
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np
import torch
from torch import nn

from racer.shared.deepracer.hyperparameters import Hyperparameters
from racer.shared.episode import Episode
from racer.shared.policy.networks import ActionDistribution, ActorCritic
from racer.trainer.clip_schedule import CONSTANT_ONE, ClipSchedule
from racer.trainer.device import exact_fp32
from racer.trainer.gae import GAE_LAMBDA, compute_gae
from racer.trainer.kl_adaptive_lr import KLAdaptiveRate
from racer.trainer.learner import ADAM_BETAS, ADAM_EPSILON, UpdateAbandoned, adam, seed_or_fresh
from racer.trainer.log_lines import format_policy_training_line
from racer.trainer.nan_guard import (
    NanGuard,
    NonFiniteError,
    check_finite,
    finite_episodes,
    first_non_finite_parameter,
    gradient_norm,
)
from racer.trainer.ppo_batch import (
    TrainingBatch,
    cat_distributions,
    make_training_batch,
    minibatch_size_for,
    old_log_probs,
    shuffled_minibatches,
    slice_distribution,
)
from racer.trainer.precision import DEFAULT_PRECISION, Precision

__all__ = [
    "CLIP_EPSILON",
    "EpochStats",
    "PPOSettings",
    "PPOLearner",
    "TrainingBatch",
    "make_training_batch",
    "minibatch_size_for",
    "shuffled_minibatches",
]

CLIP_EPSILON = 0.2
ADVANTAGE_STD_EPSILON = 1e-8
HUBER_DELTA = 1.0


@dataclass(frozen=True)
class PPOSettings:
    """What DeepRacer hard-wires (not hyperparameters), plus this trainer's own knobs."""

    clip_epsilon: float = CLIP_EPSILON
    gae_lambda: float = GAE_LAMBDA
    adam_epsilon: float = ADAM_EPSILON
    adam_betas: tuple[float, float] = ADAM_BETAS
    inference_chunk_size: int = 256
    """Transitions per forward pass when evaluating V(s) and the old policy before the epochs (bounds memory)."""
    max_nan_retries: int = 3
    """Rollback-and-halve attempts per update before the iteration's data is skipped."""
    seed: int | None = None
    """Seeds the minibatch shuffling; None draws a fresh seed."""
    threads_per_tower: int | None = None
    """torch intra-op threads while an update runs (restored afterwards). The policy and value towers run
    concurrently on two threads, so the update uses 2 x this many cores; None = half the CPUs available to the
    process (1 on a 2-core machine, where one thread per tower beat two threads per op, more so under load)."""
    precision: Precision = DEFAULT_PRECISION
    """What the towers' convs and dense layers compute in (heads, probabilities, losses, GAE and Adam stay fp32):
    fp32 on every CPU unless the user asks for bf16 (see racer.trainer.precision)."""
    device: str = "cpu"
    """The torch device of the network and the update (racer.trainer.device). The GAE and the minibatch shuffle stay
    on the CPU, so a seed shuffles the same on every device."""
    value_loss_weight: float = 1.0
    """The value loss's weight in the loss (a preset's `value_loss_weight`; DeepRacer: 1)."""
    max_gradient_norm: float | None = None
    """Clip the gradient to this global norm before each step (a preset's `clip_gradients`; DeepRacer: none)."""
    kl_cutoff: float | None = None
    """Stop the update's remaining epochs once an epoch's mean KL exceeds this (a preset's; DeepRacer: none)."""
    clip_schedule: ClipSchedule = CONSTANT_ONE
    """Multiplies clip_epsilon by environment steps trained on (a preset's `clipping_decay_schedule`; DeepRacer:
    constant 1; racer.trainer.clip_schedule)."""
    desired_kl: float | None = None
    """Adapt the learning rate before each step to keep the minibatch's KL near this (a preset's `desired_kl`;
    racer.trainer.kl_adaptive_lr); None, as DeepRacer, keeps `lr` fixed."""


@dataclass(frozen=True)
class EpochStats:
    """Means over the minibatches of one epoch (what DeepRacer's `Policy training>` line reports, and more)."""

    epoch: int
    surrogate_loss: float
    kl_divergence: float
    """KL(old policy || current policy), the current policy as it was before each minibatch's step."""
    entropy: float
    value_loss: float
    clip_fraction: float
    """Share of transitions whose probability ratio lay outside [1 - clip, 1 + clip]."""
    learning_rate: float
    minibatches: int
    gradient_norm: float
    clip_range: float = CLIP_EPSILON
    """The surrogate's clip range in this epoch (clip_epsilon times the clip schedule's value)."""


# --------------------------------------------------------------------------------------------------------------------
# The learner


class PPOLearner:
    """Owns the optimiser of one ActorCritic and runs DeepRacer's clipped-PPO update on lists of episodes."""

    def __init__(self, network: ActorCritic, hyperparameters: Hyperparameters, settings: PPOSettings = PPOSettings()):
        self.device = torch.device(settings.device)
        exact_fp32(self.device)
        self.network = network.to(self.device)
        self.hyperparameters = hyperparameters
        self.settings = settings
        self.optimizer = adam(network.parameters(), hyperparameters.lr, settings.adam_betas, settings.adam_epsilon)
        self.generator = torch.Generator().manual_seed(seed_or_fresh(settings.seed))
        self.nan_guard = NanGuard(network, self.optimizer, settings.max_nan_retries)
        self.tower_dtype: torch.dtype | None = Precision(settings.precision).tower_dtype
        """Autocast dtype of the towers during updates (None: fp32)."""
        self.env_steps = 0
        """Environment steps trained on so far, this update's included: the clip schedule's clock."""
        self.adaptive_rate = None if settings.desired_kl is None else KLAdaptiveRate(settings.desired_kl)
        """A preset's desired_kl: the rule that moves the learning rate before each step (None: DeepRacer's fixed lr)."""

    @property
    def nan_rollbacks(self) -> int:
        """How many times an update was rolled back because of a non-finite number (for logs and tests)."""
        return self.nan_guard.rollbacks

    @property
    def clip_range(self) -> float:
        """The clip range the surrogate uses at the current step count (constant within an update)."""
        return self.settings.clip_epsilon * self.settings.clip_schedule.value_at(self.env_steps)

    @property
    def learning_rate(self) -> float:
        return float(self.optimizer.param_groups[0]["lr"])

    @learning_rate.setter
    def learning_rate(self, value: float) -> None:
        for group in self.optimizer.param_groups:
            group["lr"] = value

    # -- public entry point ------------------------------------------------------------------------------------------

    def update(
        self,
        episodes: Sequence[Episode],
        abandon: Callable[[], bool] | None = None,
        env_steps: int | None = None,
        policy_version: int | None = None,
    ) -> list[EpochStats]:
        """One PPO iteration on these episodes. Returns per-epoch stats ([] when nothing was trained).

        `abandon()` is asked before every minibatch; True raises `UpdateAbandoned` (a stopping trainer that cannot
        wait for a long update). `env_steps`: the run's environment steps trained on, these episodes' included (the
        trainer's count, which survives a resume); None adds these transitions to the trainer's own count.
        `policy_version`: the network's checkpoint number; an episode of an older one (an overlapped run) has its
        ratio taken against its own log-probabilities."""
        episodes = finite_episodes(episodes)
        if not episodes:
            return []
        batch = make_training_batch(episodes, self.network.input_names, self.network.config, policy_version)
        batch = batch.to(self.device)
        self.env_steps = env_steps if env_steps is not None else self.env_steps + batch.size
        stats = self.nan_guard.run(lambda: self._train(batch, abandon), skipped=f"{batch.size} transitions")
        return stats if stats is not None else []

    def training_lines(self, stats: Sequence[EpochStats]) -> list[str]:
        """DeepRacer's `Policy training>` line, one per epoch."""
        return [format_policy_training_line(epoch) for epoch in stats]

    def take_late_episode(self, episode, iteration: int) -> bool:
        """Clipped PPO is strictly on-policy: an episode of an older policy is never kept."""
        return False

    # -- the algorithm -----------------------------------------------------------------------------------------------

    @torch.no_grad()
    def _evaluate_old_policy(
        self, batch: TrainingBatch, towers: ThreadPoolExecutor
    ) -> tuple[ActionDistribution, torch.Tensor]:
        """The frozen old policy and V(s) for every transition, in chunks; the value tower on the second thread."""
        chunks = [
            torch.arange(start, min(start + self.settings.inference_chunk_size, batch.size))
            for start in range(0, batch.size, self.settings.inference_chunk_size)
        ]
        values = towers.submit(self._values, batch, chunks)  # grad mode is per thread: _values has its own no_grad
        distributions = [self.network.distribution(batch.select(chunk), self.tower_dtype) for chunk in chunks]
        return cat_distributions(distributions), values.result()

    @torch.no_grad()
    def _values(self, batch: TrainingBatch, chunks: list[torch.Tensor]) -> torch.Tensor:
        return torch.cat([self.network.value(batch.select(chunk), self.tower_dtype) for chunk in chunks])

    def _value_loss_backward(self, observations: Mapping[str, torch.Tensor], targets: torch.Tensor) -> torch.Tensor:
        """Value loss of one minibatch, back-propagated into the value tower (runs on the second thread)."""
        value = self.network.value(observations, self.tower_dtype)
        if self.hyperparameters.loss_type == "huber":
            value_loss = nn.functional.huber_loss(value, targets, delta=HUBER_DELTA)
        else:
            value_loss = nn.functional.mse_loss(value, targets)
        if self.settings.value_loss_weight == 1.0:
            value_loss.backward()
        else:
            (self.settings.value_loss_weight * value_loss).backward()
        return value_loss.detach()

    def _train(self, batch: TrainingBatch, abandon: Callable[[], bool] | None = None) -> list[EpochStats]:
        threads = self.settings.threads_per_tower or max(1, len(os.sched_getaffinity(0)) // 2)
        previous_threads = torch.get_num_threads()
        torch.set_num_threads(threads)
        try:
            with ThreadPoolExecutor(max_workers=1, thread_name_prefix="value-tower") as towers:
                return self._epochs(batch, towers, abandon)
        finally:
            torch.set_num_threads(previous_threads)

    def _epochs(
        self, batch: TrainingBatch, towers: ThreadPoolExecutor, abandon: Callable[[], bool] | None = None
    ) -> list[EpochStats]:
        hp = self.hyperparameters
        clip = self.clip_range

        # Old policy and values, frozen before the first step.
        old_policy, values = self._evaluate_old_policy(batch, towers)
        check_finite(float(values.sum()), "V(s) of the rollout")

        # GAE with zero bootstrap after every episode, then advantages standardised over the iteration.
        advantages, value_targets = compute_gae(
            batch.rewards.numpy(),
            values.cpu().numpy(),
            batch.episode_ends.numpy(),
            hp.discount_factor,
            self.settings.gae_lambda,
        )
        advantages = (advantages - advantages.mean()) / (advantages.std() + ADVANTAGE_STD_EPSILON)
        advantages = torch.from_numpy(advantages.astype(np.float32)).to(self.device)
        value_targets = torch.from_numpy(value_targets.astype(np.float32)).to(self.device)

        minibatch_size = minibatch_size_for(batch.size, hp.batch_size)
        stats = []
        for epoch in range(hp.num_epochs):
            sums = dict.fromkeys(("surrogate", "kl", "entropy", "value", "clipped", "grad_norm"), 0.0)
            minibatches = shuffled_minibatches(batch.size, minibatch_size, self.generator)
            for number, indices in enumerate(minibatches):
                if abandon is not None and abandon():
                    raise UpdateAbandoned()
                observations = batch.select(indices)
                self.optimizer.zero_grad(set_to_none=True)

                # Value loss against the GAE targets: forward and backward on the second thread, while the policy
                # tower works here. The towers share no weight, so these are exactly the gradients of the summed loss.
                value_loss_job = towers.submit(self._value_loss_backward, observations, value_targets[indices])

                # Clipped surrogate objective, against the frozen old policy.
                old = slice_distribution(old_policy, indices)
                new = self.network.distribution(observations, self.tower_dtype)
                with torch.no_grad():
                    kl = float(new.kl_from(old).mean())  # KL(old || the policy before this step)
                if self.adaptive_rate is not None:
                    self.learning_rate = self.adaptive_rate.next_rate(self.learning_rate, kl)
                actions = batch.actions[indices]
                ratio = torch.exp(new.log_prob(actions) - old_log_probs(batch, indices, old.log_prob(actions)))
                advantage = advantages[indices]
                surrogate = -torch.min(ratio * advantage, ratio.clamp(1 - clip, 1 + clip) * advantage).mean()

                # Entropy bonus.
                entropy = new.entropy().mean()

                # loss = value loss + surrogate - beta * entropy; one Adam step for both towers.
                (surrogate - hp.beta_entropy * entropy).backward()
                value_loss = value_loss_job.result()
                loss = (
                    self.settings.value_loss_weight * value_loss
                    + surrogate.detach()
                    - hp.beta_entropy * entropy.detach()
                )
                where = f"epoch {epoch}, minibatch {number}"
                check_finite(loss.item(), f"loss at {where}")
                grad_norm = gradient_norm(self.network.parameters())
                check_finite(grad_norm, f"gradient at {where}")
                if self.settings.max_gradient_norm is not None:
                    nn.utils.clip_grad_norm_(self.network.parameters(), self.settings.max_gradient_norm)
                self.optimizer.step()

                with torch.no_grad():
                    sums["surrogate"] += float(surrogate)
                    sums["kl"] += kl
                    sums["entropy"] += float(entropy)
                    sums["value"] += float(value_loss)
                    sums["clipped"] += float(((ratio - 1).abs() > clip).float().mean())
                    sums["grad_norm"] += grad_norm

            bad_weight = first_non_finite_parameter(self.network)
            if bad_weight is not None:
                raise NonFiniteError(f"weight {bad_weight} after epoch {epoch}")
            count = max(1, len(minibatches))
            stats.append(
                EpochStats(
                    epoch=epoch,
                    surrogate_loss=sums["surrogate"] / count,
                    kl_divergence=sums["kl"] / count,
                    entropy=sums["entropy"] / count,
                    value_loss=sums["value"] / count,
                    clip_fraction=sums["clipped"] / count,
                    learning_rate=self.learning_rate,
                    minibatches=len(minibatches),
                    gradient_norm=sums["grad_norm"] / count,
                    clip_range=clip,
                )
            )
            if self.settings.kl_cutoff is not None and stats[-1].kl_divergence > self.settings.kl_cutoff:
                break  # the preset's KL cut-off: the policy moved far enough for this iteration
        return stats
