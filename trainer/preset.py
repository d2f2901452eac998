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
- `desired_kl` (null, rsl_rl's name: RL Coach has none): adapt the learning rate before each minibatch's step to
  keep its KL(old || current) within a factor 2 of this (racer.trainer.kl_adaptive_lr); null keeps `lr` fixed.
- `anneal_lr` (false, CleanRL's name: RL Coach has none): before each update, `lr` x the share of the run still to
  go (its time limit or episode limit, whichever stops it sooner), so the rate reaches 0 at the run's end
  (racer.trainer.lr_anneal); not with `desired_kl`, which moves the rate by another rule.
- `clipping_decay_schedule` ({"type": "constant", "value": 1}): multiplies the clip range by environment steps
  trained on; or {"type": "linear", "initial_value", "final_value", "decay_steps"} (racer.trainer.clip_schedule).
SAC:
- `rate_for_copying_weights_to_target` (1.0, tau): V_target <- tau V + (1 - tau) V_target at each copy.
- `updates_per_transition` (unset: `--sac-updates-per-transition`, default 1 = DeepRacer; racer's name): gradient
  steps per transition received. RL Coach runs an absolute `num_consecutive_training_steps` per training phase
  (IntelLabs/coach v1.0.0 `rl_coach/agents/agent.py`, `Agent.train`), which DeepRacer sets to the iteration's
  rollout steps (aws-deepracer-community/deepracer-simapp v5.3.3, commit 608b024b,
  `bundle/markov/training_worker.py`); this key is that count divided by the iteration's transitions. Given with a different `--sac-updates-per-transition`, the run
  is refused (neither silently wins).

The entropy weight is hyperparameters.json's `beta_entropy` (RL Coach's clipped PPO has one, the same) and SAC's
alpha is its `sac_alpha`: a preset refuses them, as it refuses every key it does not know, naming them. Every default
is DeepRacer's, so a run with a preset that sets the defaults is the run without a preset, bit for bit.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, fields, replace
from pathlib import Path

from racer.shared.deepracer.hyperparameters import Hyperparameters
from racer.trainer.clip_schedule import CONSTANT_ONE, ClipSchedule, ClipScheduleError, parse_clip_schedule
from racer.trainer.gae import GAE_LAMBDA
from racer.trainer.learner import ADAM_BETAS, ADAM_EPSILON
from racer.trainer.ppo import CLIP_EPSILON, PPOSettings
from racer.trainer.sac import SACSettings

__all__ = ["PRESET_FILE", "Preset", "PresetError", "load_preset", "parse_preset", "sac_updates_per_transition"]

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
    desired_kl: float | None = None
    anneal_lr: bool = False
    rate_for_copying_weights_to_target: float = 1.0
    clipping_decay_schedule: ClipSchedule = CONSTANT_ONE
    updates_per_transition: float | None = None
    """None: the preset does not set it (the command line's, default 1)."""

    def to_dict(self) -> dict:
        """Plain JSON values, as a checkpoint manifest's `extra.preset` stores them."""
        values = {field.name: getattr(self, field.name) for field in fields(self)}
        return values | {"clipping_decay_schedule": self.clipping_decay_schedule.to_dict()}

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
            desired_kl=self.desired_kl,
            clip_schedule=self.clipping_decay_schedule,
        )

    def sac_settings(self, base: SACSettings) -> SACSettings:
        """`base` with the preset's SAC keys (check a command line's ratio with `sac_updates_per_transition` first)."""
        settings = replace(base, target_copy_rate=self.rate_for_copying_weights_to_target)
        if self.updates_per_transition is None:
            return settings
        return replace(settings, updates_per_transition=self.updates_per_transition)


PPO_KEYS = (
    "clip_likelihood_ratio_using_epsilon",
    "gae_lambda",
    "value_loss_weight",
    "optimizer_epsilon",
    "adam_optimizer_beta1",
    "adam_optimizer_beta2",
    "clip_gradients",
    "kl_cutoff",
    "desired_kl",
    "anneal_lr",
    "clipping_decay_schedule",
)
SAC_KEYS = ("rate_for_copying_weights_to_target", "updates_per_transition")
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
    "desired_kl": (0.0, math.inf, False),
    "rate_for_copying_weights_to_target": (0.0, 1.0, False),
    "updates_per_transition": (0.0, math.inf, False),
}
_NULLABLE = ("clip_gradients", "kl_cutoff", "desired_kl")


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
    values: dict[str, object] = {}
    for key, value in data.items():
        if key == "clipping_decay_schedule":
            continue  # after the clip range it multiplies
        if key == "anneal_lr":
            if not isinstance(value, bool):
                raise PresetError(f"{source}: anneal_lr: {value!r} is not true or false")
            values[key] = value
            continue
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
    if values.get("anneal_lr") and values.get("desired_kl") is not None:
        raise PresetError(
            f"{source}: anneal_lr and desired_kl: both move the learning rate, by different rules; fix: keep one"
        )
    if "clipping_decay_schedule" in data:
        clip_epsilon = values.get("clip_likelihood_ratio_using_epsilon", CLIP_EPSILON)
        try:
            values["clipping_decay_schedule"] = parse_clip_schedule(data["clipping_decay_schedule"], clip_epsilon)
        except ClipScheduleError as error:
            raise PresetError(f"{source}: clipping_decay_schedule: {error}") from error
    return Preset(**values)


def sac_updates_per_transition(option: float | None, preset: Preset | None, source: str = PRESET_FILE) -> float:
    """SAC's gradient steps per transition: the preset's or `--sac-updates-per-transition` (`option`, None when not
    given), else DeepRacer's 1. Both given and different is refused: neither may silently override the other."""
    from_preset = preset.updates_per_transition if preset is not None else None
    if option is not None and from_preset is not None and option != from_preset:
        raise PresetError(
            f"{source}: updates_per_transition: {from_preset:g} conflicts with --sac-updates-per-transition "
            f"{option:g}; fix: give it in one place"
        )
    for value in (option, from_preset):
        if value is not None:
            return value
    return 1.0


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
