"""Where the next episode starts: the round-robin start and driving direction carried across training episodes
(per env = per rollout worker, as in the SimApp), the episode counters, and `reset()`'s options."""

from __future__ import annotations

from typing import Any

from racer.shared.sim.config import EnvConfig

RESET_OPTIONS = ("evaluation", "start_ndist", "clear_start", "max_steps", "start_offset")


class StartRotation:
    """Training episodes start at `start_position_offset` and advance by `round_robin_advance_dist` of a lap after
    each finished one (`change_start_position`); `alternate_driving_direction` flips the direction after each.
    Evaluation episodes change neither."""

    def __init__(self, config: EnvConfig) -> None:
        self._config = config
        self.start_ndist = config.start_position_offset % 1.0
        self.reverse_dir = config.reverse_dir
        self.training_episodes_done = 0
        self.evaluation_episodes_done = 0

    def episode_index(self, evaluation: bool) -> int:
        return self.evaluation_episodes_done if evaluation else self.training_episodes_done

    def finish(self, evaluation: bool) -> None:
        """End-of-episode bookkeeping: only training episodes move the start and flip the direction."""
        if evaluation:
            self.evaluation_episodes_done += 1
            return
        self.training_episodes_done += 1
        if self._config.change_start_position:
            self.start_ndist = (self.start_ndist + self._config.round_robin_advance_dist) % 1.0
        if self._config.alternate_driving_direction:
            self.reverse_dir = not self.reverse_dir


def read_reset_options(options: dict[str, Any] | None, next_start_ndist: float) -> tuple[bool, float]:
    """(evaluation?, start ndist) from `reset()`'s options; an evaluation episode may start at `start_ndist`."""
    options = options or {}
    unknown = set(options) - set(RESET_OPTIONS)
    if unknown:
        raise ValueError(
            f"unknown reset option(s) {sorted(unknown)}; supported: {', '.join(repr(name) for name in RESET_OPTIONS)}"
        )
    evaluation = bool(options.get("evaluation", False))
    if options.get("start_ndist") is None:
        return evaluation, next_start_ndist
    if not evaluation:
        raise ValueError(
            "reset option 'start_ndist' is for evaluation episodes; training episodes start at the round-robin position"
        )
    return evaluation, float(options["start_ndist"]) % 1.0


def episode_max_steps(options: dict[str, Any] | None, config_max_steps: int) -> int:
    """The step after which this episode is truncated: `options["max_steps"]` (racer's evaluation step cap,
    RACER_EVAL_MAX_STEPS), never beyond the env's own `max_steps`; the env's when the option is absent or None."""
    wanted = (options or {}).get("max_steps")
    if wanted is None:
        return config_max_steps
    if isinstance(wanted, bool) or not isinstance(wanted, int) or wanted < 1:
        raise ValueError(f"reset option 'max_steps' must be a whole number >= 1, got {wanted!r}")
    return min(wanted, config_max_steps)


def start_offset(options: dict[str, Any] | None) -> tuple[float, float]:
    """`options["start_offset"]`: (metres to the left, radians to the left) the car starts off its start pose, for
    an evaluation episode (racer's robustness bench); (0, 0) when absent."""
    options = options or {}
    offset = options.get("start_offset")
    if offset is None:
        return 0.0, 0.0
    if not options.get("evaluation"):
        raise ValueError("reset option 'start_offset' is for evaluation episodes")
    try:
        left_m, turn_rad = (float(value) for value in offset)
    except (TypeError, ValueError):
        raise ValueError(f"reset option 'start_offset' must be (metres, radians), got {offset!r}") from None
    return left_m, turn_rad
