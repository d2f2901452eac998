"""DeepRacer's SAC update (SimApp `get_sac_params`, `SoftActorCriticAgent.learn_from_batch`, `training_worker.py`).

Public API
----------
    learner = SACLearner(networks, hyperparameters, SACSettings())   # one Adam over policy, Q and V
    stats = learner.update(episodes)            # list[SACStats] (one entry, [] when nothing was trained)
    for line in learner.training_lines(stats): print(line)
    learner.optimizer, learner.learning_rate, learner.replay

One iteration, as DeepRacer's trainer runs it:

1. The iteration's episodes go into the replay memory (`racer.trainer.replay_buffer`; every episode end is terminal).
2. Gradient steps: as many as the iteration brought transitions (`num_consecutive_training_steps = rollout steps`),
   times `SACSettings.updates_per_transition` (1.0 = DeepRacer). Minibatch: `batch_size` transitions sampled
   uniformly, or 2^floor(log2(iteration transitions)) while the memory holds no more than `batch_size`.
3. Each step, from one minibatch (s, a, r, done, s'):
       a~, log pi(a~|s) = reparameterised squashed-Gaussian sample of the policy
       policy loss = mean(sac_alpha * log pi(a~|s) - min(Q1, Q2)(s, a~))
       V loss      = mse(V(s), min(Q1, Q2)(s, a~) - sac_alpha * log pi(a~|s))     (Huber with loss_type huber)
       Q loss      = 0.5 mean((Q1(s, a) - y)^2) + 0.5 mean((Q2(s, a) - y)^2),  y = r + gamma (1 - done) V_target(s')
   The policy gradient does not reach Q's weights; all three use the networks as they were before the step, so one
   Adam step over all of them (lr, betas 0.9/0.999, eps 1e-5, no clipping) equals DeepRacer's three.
   Speed, not arithmetic: the networks share no weight, so each step runs on two threads with one torch thread each
   (as PPO's towers). The Q loss reads no policy output, so one thread computes Q (forward and backward), V's
   forward and V_target; the other the policy (forward and backward), then V's backward. Q's first layer is linear
   in the action, so the policy's Q values reuse its product with the 11264 state features.
   OpenMP threads spread over a busy 2-core machine wait for each other at every layer; two plain threads do not.
4. V_target = V, copied once per iteration after its first gradient step (tau = 1 with DeepRacer's
   `num_steps_between_copying_online_weights_to_target = EnvironmentSteps(episodes)`, which passes once per fetch).
Non-finite numbers roll back to the state before the update and halve the learning rate, as for PPO
(`racer.trainer.nan_guard`).
"""

from __future__ import annotations

import logging
import math
import os
from collections.abc import Callable, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np
import torch
from torch import nn

from racer.shared.deepracer.hyperparameters import Hyperparameters
from racer.shared.episode import Episode
from racer.shared.policy.sac_networks import QAtStoredActions, SACNetworks
from racer.trainer.device import exact_fp32
from racer.trainer.learner import UpdateAbandoned, adam, seed_or_fresh
from racer.trainer.log_lines import format_sac_training_line
from racer.trainer.nan_guard import (
    NanGuard,
    NonFiniteError,
    check_finite,
    finite_episodes,
    first_non_finite_parameter,
    gradient_norm,
)
from racer.trainer.ppo import HUBER_DELTA
from racer.trainer.precision import DEFAULT_PRECISION, Precision
from racer.trainer.replay_buffer import ReplayBatch, ReplayBuffer

__all__ = ["SACSettings", "SACStats", "SACLearner", "sac_minibatch_size"]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class SACSettings:
    replay_memory_bytes: int = 1 << 30
    """Memory budget of the replay ring (see racer.trainer.replay_buffer): 1 GiB by default."""
    updates_per_transition: float = 1.0
    """Gradient steps per transition received; DeepRacer: 1. Lower trades sample efficiency for trainer time."""
    max_nan_retries: int = 3
    seed: int | None = None
    threads_per_tower: int | None = None
    """torch intra-op threads of each of the update's two threads (restored afterwards); None = half the CPUs this
    process may use, at least 1 (as PPOSettings.threads_per_tower)."""
    precision: Precision = DEFAULT_PRECISION
    """What the towers compute in (as PPOSettings.precision): fp32 unless the user asks for bf16."""
    device: str = "cpu"
    """The torch device of the networks and gradient steps (racer.trainer.device); the replay memory stays in host
    memory and each minibatch is copied over."""
    target_copy_rate: float = 1.0
    """tau of V_target <- tau V + (1 - tau) V_target (a preset's `rate_for_copying_weights_to_target`; DeepRacer: 1)."""


@dataclass(frozen=True)
class SACStats:
    gradient_steps: int
    minibatch_size: int
    policy_loss: float
    q_loss: float
    value_loss: float
    entropy: float
    """-mean log pi(a~|s) of the sampled actions."""
    mean_q: float
    learning_rate: float
    gradient_norm: float
    replay_transitions: int


def sac_minibatch_size(replay_transitions: int, iteration_transitions: int, batch_size: int) -> int:
    """DeepRacer's training_worker: `batch_size` once the memory holds more, else 2^floor(log2(iteration steps))."""
    if replay_transitions > batch_size:
        return batch_size
    return 2 ** int(math.floor(math.log2(max(1, iteration_transitions))))


class SACLearner:
    def __init__(self, networks: SACNetworks, hyperparameters: Hyperparameters, settings: SACSettings | None = None):
        settings = settings or SACSettings()
        self.device = torch.device(settings.device)
        exact_fp32(self.device)
        self.networks = networks.to(self.device)
        self.hyperparameters = hyperparameters
        self.settings = settings
        self.optimizer = adam(networks.trainable_parameters(), hyperparameters.lr)
        seed = seed_or_fresh(settings.seed)
        self.rng = np.random.default_rng(seed)
        self.generator = torch.Generator().manual_seed(seed)
        self.replay = ReplayBuffer(networks.config.inputs, settings.replay_memory_bytes, networks.config.stack_size)
        self.nan_guard = NanGuard(networks, self.optimizer, settings.max_nan_retries)
        self.tower_dtype: torch.dtype | None = Precision(settings.precision).tower_dtype

    @property
    def network(self) -> SACNetworks:
        """The learner's network (policy, twin Q, V and V_target): what checkpoints save."""
        return self.networks

    @property
    def nan_rollbacks(self) -> int:
        return self.nan_guard.rollbacks

    @property
    def learning_rate(self) -> float:
        return float(self.optimizer.param_groups[0]["lr"])

    @learning_rate.setter
    def learning_rate(self, value: float) -> None:
        for group in self.optimizer.param_groups:
            group["lr"] = value

    def add_experience(self, episodes: Sequence[Episode]) -> int:
        """Store finite episodes in the replay memory (also used for late episodes of the previous checkpoint)."""
        kept = finite_episodes(episodes)
        for episode in kept:
            self.replay.add_episode(episode)
        return sum(episode.steps for episode in kept)

    def update(
        self,
        episodes: Sequence[Episode],
        abandon: Callable[[], bool] | None = None,
        env_steps: int | None = None,
        policy_version: int | None = None,
    ) -> list[SACStats]:
        """Store the episodes, then train; `abandon()` is asked before every gradient step (True raises
        `UpdateAbandoned`: a stopping trainer that cannot wait for a long update). `env_steps` is unused: SAC has no
        schedule over the run's steps; nor is `policy_version`: SAC learns off-policy."""
        transitions = self.add_experience(episodes)
        if transitions == 0:
            return []
        steps = max(1, round(transitions * self.settings.updates_per_transition))
        minibatch = sac_minibatch_size(len(self.replay), transitions, self.hyperparameters.batch_size)
        stats = self.nan_guard.run(lambda: [self._train(steps, minibatch, abandon)], skipped=f"{steps} gradient steps")
        return stats if stats is not None else []

    def training_lines(self, stats: Sequence[SACStats]) -> list[str]:
        """One `Policy training>` line per iteration."""
        return [format_sac_training_line(entry) for entry in stats]

    def take_late_episode(self, episode, iteration: int) -> bool:
        """SAC learns off-policy: a late episode played with the previous checkpoint (an episode played again for a
        worker that came back, a worker that finished after the trainer moved on) is still good experience. Anything
        older is dropped: what enters the memory during iteration k was played by checkpoint k or k-1."""
        if episode.policy_version != iteration - 1 or episode.iteration >= iteration:
            return False
        log.info(
            "SAC: an episode of checkpoint %d (one behind) from worker %d goes into the replay memory",
            episode.policy_version,
            episode.worker_id,
        )
        self.add_experience([episode])
        return True

    def _train(self, steps: int, minibatch: int, abandon: Callable[[], bool] | None = None) -> SACStats:
        threads = self.settings.threads_per_tower or max(1, len(os.sched_getaffinity(0)) // 2)
        previous_threads = torch.get_num_threads()
        torch.set_num_threads(threads)
        try:
            sums = dict.fromkeys(("policy", "q", "v", "entropy", "mean_q", "grad_norm"), 0.0)
            with ThreadPoolExecutor(max_workers=1, thread_name_prefix="sac-critic") as critic:
                for step in range(steps):
                    if abandon is not None and abandon():
                        raise UpdateAbandoned()
                    for key, value in self._step(minibatch, step, critic).items():
                        sums[key] += value
                    if step == 0:
                        self.networks.sync_target(self.settings.target_copy_rate)
            bad_weight = first_non_finite_parameter(self.networks)
            if bad_weight is not None:
                raise NonFiniteError(f"weight {bad_weight} after {steps} gradient steps")
        finally:
            torch.set_num_threads(previous_threads)
        return SACStats(
            gradient_steps=steps,
            minibatch_size=minibatch,
            policy_loss=sums["policy"] / steps,
            q_loss=sums["q"] / steps,
            value_loss=sums["v"] / steps,
            entropy=sums["entropy"] / steps,
            mean_q=sums["mean_q"] / steps,
            learning_rate=self.learning_rate,
            gradient_norm=sums["grad_norm"] / steps,
            replay_transitions=len(self.replay),
        )

    def _critic_q(self, batch: ReplayBatch) -> QAtStoredActions:
        return self.networks.q_values_at_stored_actions(
            self.networks.q_features(batch.observations, self.tower_dtype), batch.actions
        )

    def _critic_q_loss(self, batch: ReplayBatch, q: Future[QAtStoredActions]) -> float:
        """Q towards r + gamma (1 - done) V_target(s'), forward and backward: the Q loss reads no policy output."""
        next_value = self.networks.target_value(batch.next_observations, self.tower_dtype)
        td_target = batch.rewards + self.hyperparameters.discount_factor * (1.0 - batch.dones) * next_value
        stored = q.result()
        q_loss = 0.5 * (stored.q1 - td_target).square().mean() + 0.5 * (stored.q2 - td_target).square().mean()
        q_loss.backward()
        return float(q_loss.detach())

    def _step(self, minibatch: int, step: int, critic: ThreadPoolExecutor) -> dict[str, float]:
        hp, nets, dtype = self.hyperparameters, self.networks, self.tower_dtype
        batch = self.replay.sample(minibatch, self.rng).to(self.device)
        self.optimizer.zero_grad(set_to_none=True)

        # The critic thread, in this order: Q at the minibatch's actions (which the policy loss reads first), V(s),
        # then V_target(s') and the Q loss's forward and backward. This thread: the policy, its loss and backward,
        # then V's loss and backward. The graphs share no tensor that needs a gradient.
        q_future = critic.submit(self._critic_q, batch)
        value_future = critic.submit(nets.value, batch.observations, dtype)
        q_loss_future = critic.submit(self._critic_q_loss, batch, q_future)
        sample = nets.sample(batch.observations, self.generator, dtype)

        # Policy: reparameterised sample, scored by the twin Q on the same states (Q's weights held constant).
        q1_new, q2_new = nets.q_values_for_policy(q_future.result(), sample.action)
        min_q_new = torch.min(q1_new, q2_new)
        policy_loss = (hp.sac_alpha * sample.log_prob - min_q_new).mean()
        value_target = (min_q_new - hp.sac_alpha * sample.log_prob).detach()
        policy_loss.backward()

        # V towards the soft value of the sampled action.
        value = value_future.result()
        if hp.loss_type == "huber":
            value_loss = nn.functional.huber_loss(value, value_target, delta=HUBER_DELTA)
        else:
            value_loss = nn.functional.mse_loss(value, value_target)
        value_loss.backward()
        q_value = q_loss_future.result()

        policy_value, value_value = float(policy_loss.detach()), float(value_loss.detach())
        check_finite(policy_value + value_value + q_value, f"loss at gradient step {step}")
        grad_norm = gradient_norm(nets.trainable_parameters())
        check_finite(grad_norm, f"gradient at gradient step {step}")
        self.optimizer.step()
        return {
            "policy": policy_value,
            "q": q_value,
            "v": value_value,
            "entropy": -float(sample.log_prob.detach().mean()),
            "mean_q": float(min_q_new.detach().mean()),
            "grad_norm": grad_norm,
        }
