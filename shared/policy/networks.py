"""DeepRacer's clipped-PPO actor-critic in PyTorch (deepracer-simapp v5.3.3 `bundle/markov/sensors/utils.py`,
`bundle/markov/architecture/custom_architectures.py`).

Public API
----------
- `PolicyConfig` (frozen, `policy_config.py`, importable from here too): what defines a network -- `neural_network`,
  the inputs (`InputSpec`, sorted by name) and the action space. `policy_config_from_metadata(model_metadata)`
  derives it from a parsed `model_metadata.json`; `to_dict()` / `from_dict()` round-trip it through JSON.
- `build_actor_critic(model_metadata) -> ActorCritic`, or `ActorCritic(policy_config)`.
- `ActorCritic.distribution(obs) -> CategoricalPolicy | GaussianPolicy` (policy tower), `ActorCritic.value(obs)`
  (value tower, shape (B,)), `ActorCritic.policy_output(obs)` (what the exported model outputs: action probabilities
  or the Gaussian mean, DeepRacer's linear head output).
- `ActorCritic.act(observation, greedy, generator=None, epsilon=0.0) -> (action, log_prob)`: one observation as a dict
  of numpy arrays (sensor name -> array without batch axis), for the rollout and evaluation workers;
  `select_action(distribution, ...)` is the sampling rule it applies (argmax/mean, sampling, e-greedy), numpy code
  from racer.shared.policy.action_selection, which the torch-free workers run on ONNX Runtime's outputs.
- `e_greedy_epsilon(env_step, final_epsilon, decay_steps)` (from action_selection): DeepRacer's `LinearSchedule(1.0, e_greedy_value,
  epsilon_steps)` for the `e-greedy` exploration type.
- `conv_output_shape(...)`, `NETWORK_ARCHITECTURES`: the layer tables, exposed for tests and tools.

Input convention: observations are batched exactly as episodes store them -- cameras (B, 120, 160, C) with raw 0-255
grayscale values (uint8 or float), lidar (B, n) float. The network divides images by 255 itself. Channels-last is
kept end to end (a (B, H, W, C) array viewed as NCHW *is* PyTorch's channels_last layout, so no copy), and conv
features are flattened in (H, W, C) order, Keras' order, so weights map one to one onto a TF-style graph.

Layers (racer.shared.policy.layers, the table; racer.shared.policy.layer_modules, its torch modules): DeepRacer's
three networks have Conv2d with 'valid' padding and ReLU after every conv and dense layer of the embedders and
middleware (RL Coach's SCHEME embedders ignore the batch-norm/dropout/tanh entries of DeepRacer's scheme dicts); your
own network (network.json, racer.shared.policy.network_file, carried in
`PolicyConfig.network`) may add batch-norm, tanh or no activation, and dropout per layer. The policy
and value towers are separate copies of embedders + middleware (`use_separate_networks_per_head = True`).

Heads: discrete = Dense(num_actions) -> softmax -> max(p, 1e-8) (not renormalised, as DeepRacer). Continuous =
DeepRacer's: the mean is the linear Dense(2) output (RL Coach's `tf.identity` named `policy`, not squashed), plus a
state-independent log-std parameter (init 0, clipped to [-20, 3] where it is used). The same weights therefore act the
same in racer, in RL Coach and on the car; the environment clips the action to [-1, 1] when it scales it, as the
SimApp's does. (A checkpoint whose manifest lacks `continuous_mean` = "linear" squashed the mean with tanh; it is
refused.)
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import torch
from torch import nn

from racer.shared.policy.action_selection import (
    E_GREEDY_EVALUATION_EPSILON,
    LOG_STD_MAX,
    LOG_STD_MIN,
    e_greedy_epsilon,
    sample_categorical,
    select_discrete_action,
    select_gaussian_action,
)
from racer.shared.policy.layer_modules import conv_modules, dense_modules
from racer.shared.policy.layers import (
    LIDAR_EMBEDDER_DENSE,
    NETWORK_ARCHITECTURES,
    ConvLayer,
    DenseLayer,
    NetworkArchitecture,
    conv_output_shape,
)
from racer.shared.policy.network_file import NetworkFile
from racer.shared.policy.policy_config import CONTINUOUS_MEAN, InputSpec, PolicyConfig, policy_config_from_metadata

if TYPE_CHECKING:
    from racer.shared.deepracer.model_metadata import ModelMetadata

__all__ = [
    "CONTINUOUS_MEAN",
    "LOG_STD_MAX",
    "LOG_STD_MIN",
    "NETWORK_ARCHITECTURES",
    "ActorCritic",
    "CategoricalPolicy",
    "ConvLayer",
    "DenseLayer",
    "GaussianPolicy",
    "InputSpec",
    "LIDAR_EMBEDDER_DENSE",
    "NetworkArchitecture",
    "NetworkFile",
    "PolicyConfig",
    "build_actor_critic",
    "conv_output_shape",
    "E_GREEDY_EVALUATION_EPSILON",
    "e_greedy_epsilon",
    "policy_config_from_metadata",
    "sample_categorical",
    "select_action",
    "select_discrete_action",
]

PIXEL_SCALE = 255.0
"""RL Coach's `input_rescaling['image']`: images enter raw 0-255 and are divided inside the network."""
MIN_PROBABILITY = 1e-8
"""Discrete head floor, `max(softmax, 1e-8)` (ppo_head.py)."""


# --------------------------------------------------------------------------------------------------------------------
# Layers


def _normalized_columns_(weight: torch.Tensor, std: float) -> None:
    """RL Coach's normalized-columns init: each output unit's weight vector is Gaussian with L2 norm `std`."""
    with torch.no_grad():
        weight.normal_()
        weight.mul_(std / weight.norm(dim=1, keepdim=True))


class CameraEmbedder(nn.Module):
    """Raw (B, H, W, C) 0-255 images -> /255 -> valid convs + ReLU -> flatten (H, W, C order) -> dense + ReLU."""

    def __init__(self, spec: InputSpec, convs: Sequence[ConvLayer], dense: Sequence[DenseLayer]):
        super().__init__()
        height_px, width_px, channels = spec.shape
        self.convs = conv_modules(channels, convs)
        out_h, out_w, out_c = conv_output_shape(height_px, width_px, convs)
        self.flatten_size = out_h * out_w * out_c
        self.dense, self.out_features = dense_modules(self.flatten_size, dense)

    def forward(self, images: torch.Tensor) -> torch.Tensor:
        dtype = self.convs[0].weight.dtype
        x = images.permute(0, 3, 1, 2).to(dtype) * (1.0 / PIXEL_SCALE)  # NCHW view of NHWC memory: channels_last
        x = self.convs(x)
        x = x.permute(0, 2, 3, 1).flatten(1)  # Keras flattens (H, W, C)
        return self.dense(x)


class VectorEmbedder(nn.Module):
    """LIDAR-type inputs: dense [256, 256] + ReLU, values used as they come (no rescaling)."""

    def __init__(self, spec: InputSpec, dense: Sequence[DenseLayer]):
        super().__init__()
        self.dense, self.out_features = dense_modules(spec.shape[0], dense)

    def forward(self, values: torch.Tensor) -> torch.Tensor:
        return self.dense(values.to(self.dense[0].weight.dtype))


class Tower(nn.Module):
    """One embedder per input (sorted names), concatenated, then the middleware. Policy and value get one each."""

    def __init__(self, config: PolicyConfig):
        super().__init__()
        embedders: dict[str, nn.Module] = {}
        for spec in config.inputs:
            convs, dense = config.embedder_layers(spec)
            if spec.kind == "camera":
                embedders[spec.name] = CameraEmbedder(spec, convs, dense)
            else:
                embedders[spec.name] = VectorEmbedder(spec, dense)
        self.input_names = tuple(spec.name for spec in config.inputs)
        self.embedders = nn.ModuleDict(embedders)
        merged = sum(embedder.out_features for embedder in embedders.values())
        self.middleware, self.out_features = dense_modules(merged, config.middleware_layers)
        for module in self.modules():
            if isinstance(module, nn.Conv2d | nn.Linear):
                nn.init.xavier_uniform_(module.weight)  # Keras/TF default (glorot_uniform, zero bias)
                nn.init.zeros_(module.bias)

    def forward(self, observations: Mapping[str, torch.Tensor]) -> torch.Tensor:
        features = [self.embedders[name](observations[name]) for name in self.input_names]
        merged = features[0] if len(features) == 1 else torch.cat(features, dim=1)
        return self.middleware(merged)


# --------------------------------------------------------------------------------------------------------------------
# Action distributions


@dataclass(frozen=True)
class CategoricalPolicy:
    """Discrete head output. `probs` are softmax floored at 1e-8 and, as in DeepRacer, not renormalised."""

    probs: torch.Tensor
    """(B, num_actions)."""

    def log_prob(self, actions: torch.Tensor) -> torch.Tensor:
        return torch.log(self.probs.gather(1, actions.long().unsqueeze(1)).squeeze(1))

    def entropy(self) -> torch.Tensor:
        return -(self.probs * torch.log(self.probs)).sum(dim=1)

    def kl_from(self, old: CategoricalPolicy) -> torch.Tensor:
        """KL(old || self) per sample, the divergence DeepRacer logs."""
        return (old.probs * (torch.log(old.probs) - torch.log(self.probs))).sum(dim=1)

    def mode(self) -> torch.Tensor:
        return self.probs.argmax(dim=1)


@dataclass(frozen=True)
class GaussianPolicy:
    """Continuous head output: diagonal Gaussian over (steering, speed) in network space."""

    mean: torch.Tensor
    """(B, 2), network space (the action box is [-1, 1]; the environment clips)."""
    log_std: torch.Tensor
    """(2,) or (B, 2), already clipped to [-20, 3]."""

    def log_prob(self, actions: torch.Tensor) -> torch.Tensor:
        z = (actions - self.mean) * torch.exp(-self.log_std)
        return (-0.5 * z.square() - self.log_std - 0.5 * math.log(2 * math.pi)).sum(dim=-1)

    def entropy(self) -> torch.Tensor:
        per_dim = self.log_std + 0.5 * (1.0 + math.log(2 * math.pi))
        return per_dim.expand_as(self.mean).sum(dim=-1)

    def kl_from(self, old: GaussianPolicy) -> torch.Tensor:
        """KL(old || self) per sample, analytic for diagonal Gaussians."""
        var_ratio = torch.exp(2 * (old.log_std - self.log_std))
        mean_term = (old.mean - self.mean).square() * torch.exp(-2 * self.log_std)
        return 0.5 * (var_ratio + mean_term - 1.0 - 2 * (old.log_std - self.log_std)).sum(dim=-1)

    def mode(self) -> torch.Tensor:
        return self.mean


ActionDistribution = CategoricalPolicy | GaussianPolicy


# --------------------------------------------------------------------------------------------------------------------
# The actor-critic


def _tower_features(
    tower: Tower, observations: Mapping[str, torch.Tensor], tower_dtype: torch.dtype | None
) -> torch.Tensor:
    """A tower's output in fp32. With `tower_dtype` (the trainer's bf16 option) the convs and dense layers run under
    autocast on the observations' device; the heads, softmax and log-probabilities after it stay fp32."""
    if tower_dtype is None:
        return tower(observations)
    with torch.autocast(next(iter(observations.values())).device.type, dtype=tower_dtype):
        features = tower(observations)
    return features.float()


class ActorCritic(nn.Module):
    """Two independent towers (policy: network_1, value: network_0 in DeepRacer's graph) and their heads."""

    def __init__(self, config: PolicyConfig):
        super().__init__()
        self.config = config
        self.policy_tower = Tower(config)
        self.value_tower = Tower(config)
        self.value_head = nn.Linear(self.value_tower.out_features, 1)
        _normalized_columns_(self.value_head.weight, std=1.0)
        nn.init.zeros_(self.value_head.bias)
        self.policy_head = nn.Linear(self.policy_tower.out_features, config.num_actions)
        if config.is_continuous:
            _normalized_columns_(self.policy_head.weight, std=0.01)
            self.log_std = nn.Parameter(torch.zeros(config.num_actions))
        else:
            nn.init.xavier_uniform_(self.policy_head.weight)
        nn.init.zeros_(self.policy_head.bias)
        self.to(memory_format=torch.channels_last)

    @property
    def input_names(self) -> tuple[str, ...]:
        """Observation keys the network reads, sorted."""
        return tuple(spec.name for spec in self.config.inputs)

    # -- batched, differentiable: what the trainer uses ---------------------------------------------------------------

    def distribution(
        self, observations: Mapping[str, torch.Tensor], tower_dtype: torch.dtype | None = None
    ) -> ActionDistribution:
        head = self.policy_head(_tower_features(self.policy_tower, observations, tower_dtype))
        if self.config.is_continuous:
            log_std = self.log_std.clamp(LOG_STD_MIN, LOG_STD_MAX)
            return GaussianPolicy(mean=head, log_std=log_std)
        return CategoricalPolicy(probs=torch.softmax(head, dim=1).clamp_min(MIN_PROBABILITY))

    def value(self, observations: Mapping[str, torch.Tensor], tower_dtype: torch.dtype | None = None) -> torch.Tensor:
        return self.value_head(_tower_features(self.value_tower, observations, tower_dtype)).squeeze(1)

    def policy_output(self, observations: Mapping[str, torch.Tensor]) -> torch.Tensor:
        """What the exported inference model returns: action probabilities (discrete) or the Gaussian mean."""
        distribution = self.distribution(observations)
        return distribution.mean if isinstance(distribution, GaussianPolicy) else distribution.probs

    def forward(self, observations: Mapping[str, torch.Tensor]) -> torch.Tensor:
        return self.policy_output(observations)

    # -- one observation, numpy in and out: what the workers use -----------------------------------------------------

    def observation_to_tensors(self, observation: Mapping[str, np.ndarray]) -> dict[str, torch.Tensor]:
        """A single observation (no batch axis) -> a batch of one, without copying camera pixels."""
        tensors = {}
        for spec in self.config.inputs:
            if spec.name not in observation:
                raise KeyError(f"observation has no {spec.name!r} (has {sorted(observation)}); the model needs it")
            array = np.asarray(observation[spec.name])
            if tuple(array.shape) != spec.shape:
                raise ValueError(f"observation {spec.name!r} has shape {array.shape}, the model expects {spec.shape}")
            tensors[spec.name] = torch.from_numpy(np.ascontiguousarray(array)).unsqueeze(0)
        return tensors

    def act(
        self,
        observation: Mapping[str, np.ndarray],
        greedy: bool,
        generator: np.random.Generator | None = None,
        epsilon: float = 0.0,
    ) -> tuple[int | np.ndarray, float]:
        """Choose one action for one observation (a dict of numpy arrays without batch axis); see `select_action`.

        Runs the policy tower only, under `torch.inference_mode`. Call `torch.set_num_threads(1)` in worker
        processes: a batch of one gains nothing from more threads, and with other processes on the same cores extra
        threads make each call many times slower.
        """
        with torch.inference_mode():
            distribution = self.distribution(self.observation_to_tensors(observation))
        return select_action(distribution, greedy, generator, epsilon)


def select_action(
    distribution: ActionDistribution,
    greedy: bool,
    generator: np.random.Generator | None = None,
    epsilon: float = 0.0,
) -> tuple[int | np.ndarray, float]:
    """DeepRacer's action selection for a batch-of-one distribution. Returns (action, log-probability under it).

    greedy=False (training): sample -- discrete `choice(actions, p=probs)`, continuous `mean + std * N(0, 1)`
    (not clipped: the environment clips to [-1, 1] when it scales the action, as DeepRacer's env does).
    greedy=True (evaluation): argmax / mean.
    epsilon > 0 (discrete, `e-greedy` exploration): with probability epsilon a uniformly random action,
    otherwise the argmax. Discrete actions come back as int, continuous ones as a float32 array (2,).
    """
    rng = generator if generator is not None else np.random.default_rng()
    if isinstance(distribution, CategoricalPolicy):
        return select_discrete_action(distribution.probs[0].double().numpy(), greedy, rng, epsilon)
    return select_gaussian_action(
        distribution.mean[0].double().numpy(), distribution.log_std.double().numpy(), greedy, rng, epsilon
    )


def build_actor_critic(metadata: ModelMetadata) -> ActorCritic:
    """The freshly initialised clipped-PPO network a model_metadata.json asks for (SAC: racer.shared.policy.factory)."""
    config = policy_config_from_metadata(metadata)
    if config.training_algorithm != "clipped_ppo":
        raise ValueError(
            f"training_algorithm {config.training_algorithm!r}: build it with racer.shared.policy.factory.build_network"
        )
    return ActorCritic(config)
