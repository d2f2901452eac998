"""The schedule of clipped PPO's clip range: RL Coach's `clipping_decay_schedule`, a preset key (racer.trainer.preset).

What RL Coach does (IntelLabs/coach, tag v1.0.0, commit 2697142d5a483da7fce651624005eb29286cc101):

- `rl_coach/agents/clipped_ppo_agent.py`: `ClippedPPOAlgorithmParameters.clipping_decay_schedule` is
  `ConstantSchedule(1)`; `train_network` feeds the schedule's `current_value` to the loss, and `choose_action`
  steps the schedule once before every action, so the schedule counts environment steps (actions played).
- `rl_coach/architectures/tensorflow_components/heads/ppo_head.py`: the value multiplies the clip range, the ratio
  is clipped to [1 - epsilon * value, 1 + epsilon * value].
- `rl_coach/schedules.py`: `LinearSchedule(initial_value, final_value, decay_steps)` moves by
  (initial - final) / decay_steps per step and stops at `final_value`; `ConstantSchedule` never moves.

racer counts the environment steps the trainer has trained on, across every worker and every iteration, including
the update's own (the checkpoint's `env_steps`; episodes dropped beyond the MAX_MEMORY_STEPS cap do not count),
and reads the schedule once per update: the clip range is constant within an update, as in RL Coach, whose
schedule only moves while acting. (DeepRacer's trainer never acts -- its rollout workers do -- so on DeepRacer a
schedule other than the constant one would never have moved; racer follows RL Coach's single-process meaning.)
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

__all__ = ["CONSTANT_ONE", "ClipSchedule", "ClipScheduleError", "parse_clip_schedule"]

KEY = "clipping_decay_schedule"


class ClipScheduleError(ValueError):
    """A schedule racer cannot use; the message names the field (the caller adds the file and the key)."""


@dataclass(frozen=True)
class ClipSchedule:
    """A multiplier of the clip range, by environment steps trained on. Constant: `initial_value` throughout."""

    type: Literal["constant", "linear"] = "constant"
    initial_value: float = 1.0
    final_value: float = 1.0
    decay_steps: int = 1

    def value_at(self, env_steps: int) -> float:
        """The multiplier after `env_steps` steps: linear from initial to final over decay_steps, then final."""
        if self.type == "constant":
            return self.initial_value
        progress = min(1.0, max(0, env_steps) / self.decay_steps)
        return self.initial_value + (self.final_value - self.initial_value) * progress

    def to_dict(self) -> dict:
        """The preset's spelling (what a manifest's `extra.preset` stores)."""
        if self.type == "constant":
            return {"type": "constant", "value": self.initial_value}
        return {
            "type": "linear",
            "initial_value": self.initial_value,
            "final_value": self.final_value,
            "decay_steps": self.decay_steps,
        }


CONSTANT_ONE = ClipSchedule()
"""RL Coach's (and so DeepRacer's) default, ConstantSchedule(1): the clip range as set."""

_FIELDS = {"constant": ("type", "value"), "linear": ("type", "initial_value", "final_value", "decay_steps")}


def _multiplier(data: dict, field: str, clip_epsilon: float) -> float:
    value = data[field]
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise ClipScheduleError(f"{field}: {value!r} is not a number")
    if value <= 0 or clip_epsilon * value > 1:
        raise ClipScheduleError(
            f"{field}: {value} is outside (0, {1 / clip_epsilon:g}]: the clip range, clip_likelihood_ratio_using_epsilon "
            f"({clip_epsilon:g}) times it, must lie in (0, 1]"
        )
    return float(value)


def parse_clip_schedule(data: object, clip_epsilon: float) -> ClipSchedule:
    """Validate a preset's schedule: a known `type`, exactly its fields, multipliers that keep the clip range
    in (0, 1], a positive whole number of decay steps."""
    if not isinstance(data, dict):
        raise ClipScheduleError(f"expected an object with a type ({' or '.join(_FIELDS)}), got {data!r}")
    kind = data.get("type")
    if kind not in _FIELDS:
        raise ClipScheduleError(f"type: {kind!r} is not one of {', '.join(_FIELDS)}")
    missing = [field for field in _FIELDS[kind] if field not in data]
    if missing:
        raise ClipScheduleError(f"{', '.join(missing)}: missing; a {kind} schedule takes {', '.join(_FIELDS[kind])}")
    unknown = sorted(field for field in data if field not in _FIELDS[kind])
    if unknown:
        raise ClipScheduleError(
            f"{', '.join(unknown)}: unknown field(s); a {kind} schedule takes {', '.join(_FIELDS[kind])}"
        )
    if kind == "constant":
        value = _multiplier(data, "value", clip_epsilon)
        return ClipSchedule("constant", value, value)
    decay_steps = data["decay_steps"]
    if isinstance(decay_steps, float) and decay_steps.is_integer():  # JSON's 1e5
        decay_steps = int(decay_steps)
    if isinstance(decay_steps, bool) or not isinstance(decay_steps, int) or decay_steps <= 0:
        raise ClipScheduleError(f"decay_steps: {decay_steps!r} is not a positive whole number of environment steps")
    return ClipSchedule(
        "linear",
        _multiplier(data, "initial_value", clip_epsilon),
        _multiplier(data, "final_value", clip_epsilon),
        decay_steps,
    )
