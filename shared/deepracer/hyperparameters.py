"""`hyperparameters.json`: the training settings of a DeepRacer model, with the SimApp defaults for missing keys.

Values may be JSON numbers or numeric strings (SageMaker passes hyperparameters as strings). Ranges are the ones
the console / DRoA offered; `term_cond_avg_score` is only checked for being a number because the SimApp ignores it
and real DRfC files use values (350, 1000) below the console's minimum. Unknown keys are reported as warnings, as
the SimApp ignores them. The resolved dict the trainer writes to `ip/hyperparameters.json` depends on the training
algorithm (PPO adds beta_entropy/num_epochs, SAC adds sac_alpha). Source: deepracer-simapp v5.3.3
`bundle/markov/sagemaker_graph_manager.py`; keys and ranges: docs/custom-files.md.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass
from os import PathLike

from racer.shared.deepracer._jsonfile import read_json_file

__all__ = [
    "BATCH_SIZES",
    "EXPLORATION_TYPES",
    "LOSS_TYPES",
    "Hyperparameters",
    "HyperparametersError",
    "hyperparameters_to_json_bytes",
    "load_hyperparameters",
    "parse_hyperparameters",
    "resolved_hyperparameters",
]


class HyperparametersError(ValueError):
    """A hyperparameters.json DeepRacer would reject; the message names the file, the key and the allowed range."""


BATCH_SIZES: tuple[int, ...] = (32, 64, 128, 256, 512)
EXPLORATION_TYPES: tuple[str, ...] = ("categorical", "e-greedy", "additive_noise")
"""`additive_noise` appears in SAC configs; the SimApp ignores exploration_type for continuous action spaces."""
LOSS_TYPES: tuple[str, ...] = ("huber", "mean squared error")

_COMMON_KEYS: tuple[str, ...] = (
    "batch_size",
    "stack_size",
    "lr",
    "exploration_type",
    "e_greedy_value",
    "epsilon_steps",
    "discount_factor",
    "loss_type",
    "num_episodes_between_training",
    "term_cond_max_episodes",
    "term_cond_avg_score",
)
_ALGORITHM_KEYS: dict[str, tuple[str, ...]] = {
    "clipped_ppo": ("beta_entropy", "num_epochs"),
    "sac": ("sac_alpha",),
}


@dataclass(frozen=True)
class Hyperparameters:
    """Field names are DeepRacer's keys; defaults are the SimApp's fallbacks (not DRfC's template values)."""

    batch_size: int = 64
    """PPO minibatch size (SAC: replay batch size)."""
    beta_entropy: float = 0.01
    """Entropy bonus coefficient (PPO only)."""
    discount_factor: float = 0.999
    e_greedy_value: float = 0.05
    """Final epsilon of the e-greedy schedule (only with exploration_type 'e-greedy')."""
    epsilon_steps: int = 10000
    exploration_type: str = "categorical"
    loss_type: str = "mean squared error"
    """Value loss: 'huber' (delta 1) or 'mean squared error'."""
    lr: float = 0.0003
    num_episodes_between_training: int = 20
    num_epochs: int = 10
    stack_size: int = 1
    """Camera frames the policy sees (RL Coach observation stacking; racer.shared.policy.frame_stack). The SimApp
    parses it but fixes stacking at 1; racer stacks 1 to 8 frames."""
    term_cond_avg_score: float = 100000.0
    """Parsed by the SimApp but not used."""
    term_cond_max_episodes: int = 100000
    """Caps the number of training iterations."""
    sac_alpha: float = 0.2
    """SAC entropy temperature (SAC only)."""


@dataclass(frozen=True)
class _Rule:
    kind: type
    low: float | None = None
    high: float | None = None
    choices: tuple[object, ...] = ()

    def describe(self) -> str:
        if self.choices:
            return "one of " + ", ".join(str(choice) for choice in self.choices)
        if self.low is not None and self.high is not None:
            return f"{self.low:g} to {self.high:g}"
        if self.low is not None:
            return f"at least {self.low:g}"
        return "any finite number"


_RULES: dict[str, _Rule] = {
    "batch_size": _Rule(int, choices=BATCH_SIZES),
    "beta_entropy": _Rule(float, 0.0, 1.0),
    "discount_factor": _Rule(float, 0.0, 1.0),
    "e_greedy_value": _Rule(float, 0.0, 1.0),
    "epsilon_steps": _Rule(int, 1),
    "exploration_type": _Rule(str, choices=EXPLORATION_TYPES),
    "loss_type": _Rule(str, choices=LOSS_TYPES),
    "lr": _Rule(float, 1e-8, 1e-3),
    "num_episodes_between_training": _Rule(int, 1, 100),
    "num_epochs": _Rule(int, 3, 10),
    "stack_size": _Rule(int, 1, 8),
    "term_cond_avg_score": _Rule(float),
    "term_cond_max_episodes": _Rule(int, 1),
    "sac_alpha": _Rule(float, 0.0, 1.0),
}


def _to_number(value: object, rule: _Rule, where: str) -> int | float:
    """Accept JSON numbers and numeric strings ("64", "3e-4"); ints must be whole ("64.0" is 64, "64.5" is not)."""
    if isinstance(value, bool):
        raise HyperparametersError(f"{where}: {value!r} is not a number; allowed: {rule.describe()}")
    if isinstance(value, str):
        try:
            number = float(value.strip())
        except ValueError:
            raise HyperparametersError(f"{where}: {value!r} is not a number; allowed: {rule.describe()}") from None
    elif isinstance(value, (int, float)):
        number = value
    else:
        raise HyperparametersError(f"{where}: {value!r} is not a number; allowed: {rule.describe()}")
    if not math.isfinite(number):
        raise HyperparametersError(f"{where}: {value!r} is not a finite number; allowed: {rule.describe()}")
    if rule.kind is int:
        if not float(number).is_integer():
            raise HyperparametersError(f"{where}: {value!r} is not a whole number; allowed: {rule.describe()}")
        return int(number)
    return float(number)


def _parse_value(key: str, value: object, source: str) -> int | float | str:
    rule = _RULES[key]
    where = f"{source}: {key}"
    if rule.kind is str:
        if not isinstance(value, str):
            raise HyperparametersError(f"{where}: {value!r} is not a string; allowed: {rule.describe()}")
        text = value.strip().lower()
        if text not in rule.choices:
            raise HyperparametersError(f"{where}: {value!r} is not allowed; allowed: {rule.describe()}")
        return text
    number = _to_number(value, rule, where)
    if rule.choices and number not in rule.choices:
        raise HyperparametersError(f"{where}: {value!r} is not allowed; allowed: {rule.describe()}")
    if (rule.low is not None and number < rule.low) or (rule.high is not None and number > rule.high):
        raise HyperparametersError(f"{where}: {value!r} is out of range; allowed: {rule.describe()}")
    return number


def parse_hyperparameters(data: object, source: str = "hyperparameters.json") -> tuple[Hyperparameters, list[str]]:
    """Validate a decoded hyperparameters.json; returns the settings and one warning per unknown key."""
    if not isinstance(data, Mapping):
        raise HyperparametersError(f"{source}: expected a JSON object at the top level, got {type(data).__name__}")
    values: dict[str, int | float | str] = {}
    warnings: list[str] = []
    for key, value in data.items():
        if key in _RULES:
            values[key] = _parse_value(key, value, source)
        else:
            warnings.append(f"{source}: {key}: unknown hyperparameter, ignored (DeepRacer ignores it too)")
    return Hyperparameters(**values), warnings


def load_hyperparameters(path: str | PathLike[str]) -> tuple[Hyperparameters, list[str]]:
    """Read and validate a hyperparameters.json file; errors name the file (and line/column for bad JSON)."""
    return parse_hyperparameters(read_json_file(path, HyperparametersError), source=str(path))


def resolved_hyperparameters(
    hyperparameters: Hyperparameters, training_algorithm: str = "clipped_ppo"
) -> dict[str, int | float | str]:
    """The dict the SimApp trainer resolves: common keys plus the algorithm's own (PPO or SAC), sorted by key."""
    if training_algorithm not in _ALGORITHM_KEYS:
        raise ValueError(f"training_algorithm {training_algorithm!r}: allowed: {', '.join(_ALGORITHM_KEYS)}")
    keys = _COMMON_KEYS + _ALGORITHM_KEYS[training_algorithm]
    return {key: getattr(hyperparameters, key) for key in sorted(keys)}


def hyperparameters_to_json_bytes(hyperparameters: Hyperparameters, training_algorithm: str = "clipped_ppo") -> bytes:
    """What DeepRacer writes to `ip/hyperparameters.json`: the resolved dict, indent 2, sorted keys, no newline."""
    resolved = resolved_hyperparameters(hyperparameters, training_algorithm)
    return json.dumps(resolved, indent=2, sort_keys=True).encode("utf-8")
