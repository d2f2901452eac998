"""Training presets: `preset.json` in the custom files, the algorithm's parameters beyond DeepRacer's
hyperparameters.json, under RL Coach's names where it has them (a SageMaker notebook's `src/markov/presets/*.py`).

    {"clip_likelihood_ratio_using_epsilon": 0.1, "gae_lambda": 0.9, "clip_gradients": 1.0}

clipped PPO:
- `clip_likelihood_ratio_using_epsilon` (0.2): the surrogate's clip range.
- `gae_lambda` (0.95).
- `value_loss_weight` (1.0): RL Coach's V head `loss_weight`; the loss is weight * value loss + surrogate - entropy.
- `optimizer_epsilon` (1e-5), `adam_optimizer_beta1` (0.9), `adam_optimizer_beta2` (0.999): Adam's.
- `clip_gradients` (null): clip the gradient to this global norm before each Adam step (RL Coach's
  ClipByGlobalNorm); null, as DeepRacer, does not clip.
- `kl_cutoff` (null, racer's name: RL Coach's clipped PPO has none): stop an update's remaining epochs once an
  epoch's mean KL(old || new) exceeds it.
SAC:
- `rate_for_copying_weights_to_target` (1.0, tau): V_target <- tau V + (1 - tau) V_target at each copy.

The entropy weight is hyperparameters.json's `beta_entropy` (RL Coach's clipped PPO has one, the same) and SAC's
alpha is its `sac_alpha`: a preset refuses them, as it refuses every key it does not know, naming them. Every default
is DeepRacer's, so a run without a preset (or with one that sets the defaults) is today's run bit for bit.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, fields, replace
from pathlib import Path

from racer.shared.deepracer.hyperparameters import Hyperparameters
from racer.trainer.gae import GAE_LAMBDA
from racer.trainer.learner import ADAM_BETAS, ADAM_EPSILON
from racer.trainer.ppo import CLIP_EPSILON, PPOSettings
from racer.trainer.sac import SACSettings

__all__ = ["PRESET_FILE", "Preset", "PresetError", "load_preset", "parse_preset"]

PRESET_FILE = "preset.json"


class PresetError(ValueError):
    """A preset racer cannot use; the message names the file and the key."""


@dataclass(frozen=True)
class Preset:
    clip_likelihood_ratio_using_epsilon: float = CLIP_EPSILON
    gae_lambda: float = GAE_LAMBDA
    value_loss_weight: float = 1.0
    optimizer_epsilon: float = ADAM_EPSILON
    adam_optimizer_beta1: float = ADAM_BETAS[0]
    adam_optimizer_beta2: float = ADAM_BETAS[1]
    clip_gradients: float | None = None
    kl_cutoff: float | None = None
    rate_for_copying_weights_to_target: float = 1.0

    def to_dict(self) -> dict:
        return {field.name: getattr(self, field.name) for field in fields(self)}

    def ppo_settings(self, base: PPOSettings) -> PPOSettings:
        return replace(
            base,
            clip_epsilon=self.clip_likelihood_ratio_using_epsilon,
            gae_lambda=self.gae_lambda,
            adam_epsilon=self.optimizer_epsilon,
            adam_betas=(self.adam_optimizer_beta1, self.adam_optimizer_beta2),
            value_loss_weight=self.value_loss_weight,
            max_gradient_norm=self.clip_gradients,
            kl_cutoff=self.kl_cutoff,
        )

    def sac_settings(self, base: SACSettings) -> SACSettings:
        return replace(base, target_copy_rate=self.rate_for_copying_weights_to_target)


PPO_KEYS = (
    "clip_likelihood_ratio_using_epsilon",
    "gae_lambda",
    "value_loss_weight",
    "optimizer_epsilon",
    "adam_optimizer_beta1",
    "adam_optimizer_beta2",
    "clip_gradients",
    "kl_cutoff",
)
SAC_KEYS = ("rate_for_copying_weights_to_target",)
_RANGES: dict[str, tuple[float, float, bool]] = {
    # key: (low, high, low end included)
    "clip_likelihood_ratio_using_epsilon": (0.0, 1.0, False),
    "gae_lambda": (0.0, 1.0, True),
    "value_loss_weight": (0.0, 100.0, True),
    "optimizer_epsilon": (0.0, 1.0, False),
    "adam_optimizer_beta1": (0.0, 1.0, True),
    "adam_optimizer_beta2": (0.0, 1.0, True),
    "clip_gradients": (0.0, math.inf, False),
    "kl_cutoff": (0.0, math.inf, False),
    "rate_for_copying_weights_to_target": (0.0, 1.0, False),
}
_NULLABLE = ("clip_gradients", "kl_cutoff")


def parse_preset(data: object, training_algorithm: str, source: str = PRESET_FILE) -> Preset:
    """Validate a parsed preset.json for `training_algorithm` (`clipped_ppo` or `sac`)."""
    if not isinstance(data, dict):
        raise PresetError(f"{source}: expected a JSON object of preset parameters")
    hyperparameter_keys = {field.name for field in fields(Hyperparameters)}
    in_hyperparameters = sorted(key for key in data if key in hyperparameter_keys)
    if in_hyperparameters:
        raise PresetError(
            f"{source}: {', '.join(in_hyperparameters)}: a hyperparameters.json key; fix: set it there, not in the preset"
        )
    own, other = (PPO_KEYS, SAC_KEYS) if training_algorithm == "clipped_ppo" else (SAC_KEYS, PPO_KEYS)
    for_other = sorted(key for key in data if key in other)
    if for_other:
        raise PresetError(
            f"{source}: {', '.join(for_other)}: not a {training_algorithm} parameter (model_metadata.json's "
            f"training_algorithm); {training_algorithm} presets take: {', '.join(own)}"
        )
    unknown = sorted(key for key in data if key not in own)
    if unknown:
        raise PresetError(f"{source}: {', '.join(unknown)}: unknown preset key(s); allowed: {', '.join(own)}")
    values = {}
    for key, value in data.items():
        if value is None and key in _NULLABLE:
            values[key] = None
            continue
        low, high, low_included = _RANGES[key]
        if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
            raise PresetError(f"{source}: {key}: {value!r} is not a number")
        if value > high or value < low or (value == low and not low_included):
            bracket = "[" if low_included else "("
            raise PresetError(f"{source}: {key}: {value} is outside {bracket}{low}, {high}]")
        values[key] = float(value)
    return Preset(**values)


def load_preset(folder: str | Path, training_algorithm: str) -> Preset | None:
    """The custom files' preset.json, or None when there is none (DeepRacer's settings)."""
    path = Path(folder) / PRESET_FILE
    if not path.is_file():
        return None
    try:
        data = json.loads(path.read_text(encoding="utf-8-sig"))
    except json.JSONDecodeError as error:
        raise PresetError(f"{path}: invalid JSON at line {error.lineno}, column {error.colno}: {error.msg}") from error
    return parse_preset(data, training_algorithm, str(path))
