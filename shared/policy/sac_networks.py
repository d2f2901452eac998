"""DeepRacer's SAC networks in PyTorch (deepracer-simapp v5.3.3 `bundle/markov/sagemaker_graph_manager.py`
`get_sac_params`, `sac_agent.py`, `sac_head.py`,
`sac_q_head.py`).

Public API
----------
- `SACNetworks(policy_config)` (`policy_config.training_algorithm == "sac"`, continuous, 2 actions): the three
  networks DeepRacer builds, none sharing a weight, plus the target copy of the value network:
    policy   DeepRacer embedders + middleware -> Dense(256) ReLU -> mean Dense(2), log-std Dense(2) clipped [-20, 2]
    q        DeepRacer embedders, *no* middleware -> twin heads: concat(features, action) -> Dense(256) ReLU
             -> Dense(256) ReLU -> Dense(1), for Q1 and Q2 (the output is min(Q1, Q2))
    v        DeepRacer embedders + middleware -> Dense(1)
    v_target a copy of v (never trained; `sync_target()` copies v into it, tau = 1 as DeepRacer configures)
- `SACNetworks.sample(obs) -> SquashedSample` (reparameterised action, its log-probability), `.q_values(...)`,
  `.q_values_at_stored_actions(...) -> QAtStoredActions` and `.q_values_for_policy(stored, actions)` (the policy's
  Q values from the stored actions' first layer, weights held constant), `.value(obs)`, `.target_value(obs)`: what
  the trainer needs; `.policy_output(obs)`: the deterministic action
  tanh(mean) in the network's [-1, 1] box, which evaluation drives and the ONNX model outputs first.
- The exported ONNX model (`racer.shared.policy.onnx_export`) outputs `policy` (tanh(mean), [1, 2]), `policy_mean`
  (before tanh) and `policy_log_std` (clipped): a worker samples from it, evaluation and the car read `policy`.
- `squashed_gaussian_log_prob(raw, action, mean, log_std)`: the trainer's (torch, differentiable); the workers run its
  numpy twin in racer.shared.policy.action_selection, tested equal.

Actions live in the network's [-1, 1] box, like racer's continuous PPO: the environment maps them linearly onto
[low, high] of model_metadata.json (DeepRacer's `BoxActionSpace(low, high)` with the head rescaling). Two conscious
differences from DeepRacer's TF head, both about units only: the Q networks read the [-1, 1] action rather than
degrees and m/s (so steering does not enter Q thirty times larger than speed), and the log-probability is the
squashed Gaussian's in [-1, 1] (DeepRacer's `rescale_action_values=False` formula), so `sac_alpha` weighs the same
entropy whatever the action ranges are.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Mapping
from dataclasses import dataclass

import torch
from torch import nn

from racer.shared.policy.action_selection import SQUASH_EPSILON
from racer.shared.policy.networks import PolicyConfig, Tower

__all__ = [
    "SAC_HIDDEN_UNITS",
    "SAC_LOG_STD_MAX",
    "SAC_LOG_STD_MIN",
    "SACNetworks",
    "SquashedSample",
    "QAtStoredActions",
    "squashed_gaussian_log_prob",
]

SAC_HIDDEN_UNITS = 256
"""The policy head's Dense(256) and each Q head's two Dense(256) layers (SACPolicyHead, SACQHeadParameters)."""
SAC_LOG_STD_MIN = -20.0
SAC_LOG_STD_MAX = 2.0
"""SACPolicyHeadParameters.log_std_bounds."""


def squashed_gaussian_log_prob(
    raw: torch.Tensor, action: torch.Tensor, mean: torch.Tensor, log_std: torch.Tensor
) -> torch.Tensor:
    """log pi(a|s) of a = tanh(raw), raw ~ N(mean, exp(log_std)): Gaussian density minus sum log(1 - a^2 + eps), the
    correction clipped to [1e-10, 1] as in DeepRacer's head. Shapes (B, 2) -> (B,). The workers' numpy twin is
    racer.shared.policy.action_selection.squashed_gaussian_log_prob (tested equal)."""
    z = (raw - mean) * torch.exp(-log_std)
    gaussian = (-0.5 * z.square() - log_std - 0.5 * math.log(2 * math.pi)).sum(dim=-1)
    correction = torch.log((1.0 - action.square() + SQUASH_EPSILON).clamp(1e-10, 1.0)).sum(dim=-1)
    return gaussian - correction


@dataclass(frozen=True)
class SquashedSample:
    action: torch.Tensor
    """(B, 2) in [-1, 1], differentiable (reparameterised)."""
    log_prob: torch.Tensor
    """(B,)."""
    mean: torch.Tensor
    log_std: torch.Tensor


class SACPolicyHead(nn.Module):
    def __init__(self, in_features: int, num_actions: int):
        super().__init__()
        self.hidden = nn.Linear(in_features, SAC_HIDDEN_UNITS)
        self.mean = nn.Linear(SAC_HIDDEN_UNITS, num_actions)
        self.log_std = nn.Linear(SAC_HIDDEN_UNITS, num_actions)

    def forward(self, features: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        hidden = torch.relu(self.hidden(features))
        return self.mean(hidden), self.log_std(hidden).clamp(SAC_LOG_STD_MIN, SAC_LOG_STD_MAX)


class TwinQHead(nn.Module):
    """Q1 and Q2 over concat(state features, action); DeepRacer's SACQHead."""

    def __init__(self, in_features: int, num_actions: int):
        super().__init__()
        self.num_actions = num_actions

        def one_q() -> nn.Sequential:
            return nn.Sequential(
                nn.Linear(in_features + num_actions, SAC_HIDDEN_UNITS),
                nn.ReLU(),
                nn.Linear(SAC_HIDDEN_UNITS, SAC_HIDDEN_UNITS),
                nn.ReLU(),
                nn.Linear(SAC_HIDDEN_UNITS, 1),
            )

        self.q1 = one_q()
        self.q2 = one_q()

    def forward(self, features: torch.Tensor, actions: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        joint = torch.cat([features, actions.to(features.dtype)], dim=1)
        return self.q1(joint).squeeze(1), self.q2(joint).squeeze(1)

    def at_stored_actions(self, features: torch.Tensor, actions: torch.Tensor) -> QAtStoredActions:
        """Q1, Q2 at the minibatch's actions (the Q loss: gradients to the weights and features), keeping what
        `at_other_actions` needs."""
        joint = torch.cat([features, actions.to(features.dtype)], dim=1)
        q, first_layer = [], []
        for head in (self.q1, self.q2):
            pre_activation = head[0](joint)
            q.append(head[1:](pre_activation).squeeze(1))
            first_layer.append(pre_activation.detach())
        return QAtStoredActions(q[0], q[1], (first_layer[0], first_layer[1]), actions.to(features.dtype))

    def at_other_actions(self, stored: QAtStoredActions, actions: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Q1, Q2 of the same states at other actions (the policy's), the weights held constant: gradients reach
        those actions only. The first layer is linear in concat(features, action), so its pre-activation is the
        stored action's plus W_action (a~ - a): the (B, features) x (features, 256) product runs once per head, not
        twice, and the policy's backward pass never multiplies by it."""
        shift = actions.to(stored.actions.dtype) - stored.actions
        q = []
        for head, pre_activation in zip((self.q1, self.q2), stored.first_layer, strict=True):
            action_weight = head[0].weight[:, -self.num_actions :].detach()
            q.append(_with_constant_weights(head[1:], pre_activation + shift @ action_weight.T).squeeze(1))
        return q[0], q[1]


@dataclass(frozen=True)
class QAtStoredActions:
    q1: torch.Tensor
    q2: torch.Tensor
    """(B,) at the minibatch's actions, differentiable."""
    first_layer: tuple[torch.Tensor, torch.Tensor]
    """Each head's first-layer pre-activation (B, 256), detached."""
    actions: torch.Tensor


def _with_constant_weights(layers: nn.Sequential, x: torch.Tensor) -> torch.Tensor:
    for layer in layers:
        x = (
            nn.functional.linear(x, layer.weight.detach(), layer.bias.detach())
            if isinstance(layer, nn.Linear)
            else layer(x)
        )
    return x


def _features(tower: nn.Module, observations: Mapping[str, torch.Tensor], dtype: torch.dtype | None) -> torch.Tensor:
    """A tower's output in fp32; with `dtype` (bf16 when the user asks for it) its layers run under autocast."""
    if dtype is None:
        return tower(observations)
    with torch.autocast(next(iter(observations.values())).device.type, dtype=dtype):
        features = tower(observations)
    return features.float()


class SACNetworks(nn.Module):
    """Policy, twin Q, V and target V, each on its own copy of DeepRacer's embedders."""

    def __init__(self, config: PolicyConfig):
        super().__init__()
        if config.training_algorithm != "sac" or not config.is_continuous:
            raise ValueError(
                f"SACNetworks need a continuous SAC configuration, got {config.training_algorithm} "
                f"{config.action_space_type}"
            )
        self.config = config
        self.policy_tower = Tower(config)
        self.policy_head = SACPolicyHead(self.policy_tower.out_features, config.num_actions)
        self.q_tower = Tower(config)
        # DeepRacer's Q network has the embedders but no middleware (get_sac_params leaves it empty).
        self.q_tower.middleware = nn.Sequential()
        self.q_tower.out_features = sum(embedder.out_features for embedder in self.q_tower.embedders.values())
        self.q_head = TwinQHead(self.q_tower.out_features, config.num_actions)
        self.value_tower = Tower(config)
        self.value_head = nn.Linear(self.value_tower.out_features, 1)
        for module in (*self.policy_head.modules(), *self.q_head.modules(), self.value_head):
            if isinstance(module, nn.Linear):
                nn.init.xavier_uniform_(module.weight)  # TF Dense default and VHead(initializer='xavier')
                nn.init.zeros_(module.bias)
        self.target_value_tower = copy.deepcopy(self.value_tower)
        self.target_value_head = copy.deepcopy(self.value_head)
        for parameter in (*self.target_value_tower.parameters(), *self.target_value_head.parameters()):
            parameter.requires_grad_(False)
        self.to(memory_format=torch.channels_last)

    @property
    def input_names(self) -> tuple[str, ...]:
        return tuple(spec.name for spec in self.config.inputs)

    def trainable_parameters(self) -> list[nn.Parameter]:
        """Everything but the target copy (which only `sync_target` changes)."""
        return [parameter for parameter in self.parameters() if parameter.requires_grad]

    # -- policy -------------------------------------------------------------------------------------------------------

    def policy_distribution(
        self, observations: Mapping[str, torch.Tensor], dtype: torch.dtype | None = None
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """(mean, log_std) of the Gaussian before the tanh squash, (B, 2) each."""
        return self.policy_head(_features(self.policy_tower, observations, dtype))

    def sample(
        self,
        observations: Mapping[str, torch.Tensor],
        generator: torch.Generator | None = None,
        dtype: torch.dtype | None = None,
    ) -> SquashedSample:
        mean, log_std = self.policy_distribution(observations, dtype)
        # drawn on the CPU (the learner's generator), so a seed gives the same noise on every device
        noise = torch.randn(mean.shape, generator=generator, dtype=mean.dtype).to(mean.device)
        raw = mean + torch.exp(log_std) * noise
        action = torch.tanh(raw)
        return SquashedSample(action, squashed_gaussian_log_prob(raw, action, mean, log_std), mean, log_std)

    def policy_output(self, observations: Mapping[str, torch.Tensor]) -> torch.Tensor:
        """The deterministic action tanh(mean) in [-1, 1]: what evaluation drives (use_deterministic_for_evaluation)."""
        mean, _ = self.policy_distribution(observations)
        return torch.tanh(mean)

    def forward(self, observations: Mapping[str, torch.Tensor]) -> torch.Tensor:
        return self.policy_output(observations)

    # -- critics ------------------------------------------------------------------------------------------------------

    def q_features(self, observations: Mapping[str, torch.Tensor], dtype: torch.dtype | None = None) -> torch.Tensor:
        return _features(self.q_tower, observations, dtype)

    def q_values(self, features: torch.Tensor, actions: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        return self.q_head(features, actions)

    def q_values_at_stored_actions(self, features: torch.Tensor, actions: torch.Tensor) -> QAtStoredActions:
        return self.q_head.at_stored_actions(features, actions)

    def q_values_for_policy(
        self, stored: QAtStoredActions, policy_actions: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """Q1, Q2 at the policy's actions with the head's weights held constant: the policy loss's gradient reaches
        the action only, so the policy's backward pass computes no Q weight gradient and never touches the Q head's
        `.grad`."""
        return self.q_head.at_other_actions(stored, policy_actions)

    def value(self, observations: Mapping[str, torch.Tensor], dtype: torch.dtype | None = None) -> torch.Tensor:
        return self.value_head(_features(self.value_tower, observations, dtype)).squeeze(1)

    @torch.no_grad()
    def target_value(self, observations: Mapping[str, torch.Tensor], dtype: torch.dtype | None = None) -> torch.Tensor:
        return self.target_value_head(_features(self.target_value_tower, observations, dtype)).squeeze(1)

    @torch.no_grad()
    def sync_target(self, rate: float = 1.0) -> None:
        """Copy V into the target V (DeepRacer: rate_for_copying_weights_to_target = 1), or with `rate` < 1 move the
        target that fraction of the way: target <- rate V + (1 - rate) target (buffers are copied)."""
        if rate == 1.0:
            self.target_value_tower.load_state_dict(self.value_tower.state_dict())
            self.target_value_head.load_state_dict(self.value_head.state_dict())
            return
        with torch.no_grad():
            for target, source in (
                (self.target_value_tower, self.value_tower),
                (self.target_value_head, self.value_head),
            ):
                for key, value in source.state_dict().items():
                    kept = target.state_dict()[key]
                    kept.copy_(kept.lerp(value, rate) if value.is_floating_point() else value)
