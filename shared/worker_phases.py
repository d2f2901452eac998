"""Where a rollout worker's wall time goes: seconds per phase since it started, so a run can tell simulating from
waiting and the next speed-up is chosen from a measurement (`python -m benchmarks race-pace` reports the shares).

The worker keeps a `PhaseClock` and sends its totals in its heartbeat and in every episode it delivers (flat keys of
`Episode.info`, `episode_info`); the trainer's iteration summary keeps each worker's latest (`from_episode_info`), so
the run's iterations log holds them after Redis is gone.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping

STARTING = "starting"
"""Before its first checkpoint: importing, joining, building its envs."""
WAITING = "waiting"
"""For the trainer's next checkpoint (or its first announcement)."""
LOADING = "loading"
"""A checkpoint from the store into its policy."""
PLAYING = "playing"
"""Training episodes: stepping its envs, choosing actions, delivering episodes, uploading the iteration's simtrace."""
EVALUATING = "evaluating"
"""Worker 0's greedy evaluation of each checkpoint."""
PHASES: tuple[str, ...] = (STARTING, WAITING, LOADING, PLAYING, EVALUATING)

_INFO_PREFIX, _INFO_SUFFIX = "worker_", "_s"


class PhaseClock:
    """Wall seconds spent in each phase; one phase runs at a time, from `enter` to the next `enter`."""

    def __init__(self, phase: str = STARTING, clock: Callable[[], float] = time.monotonic) -> None:
        self._clock = clock
        self._totals = dict.fromkeys(PHASES, 0.0)
        self._phase = self._checked(phase)
        self._since = clock()

    @staticmethod
    def _checked(phase: str) -> str:
        if phase not in PHASES:
            raise ValueError(f"unknown worker phase {phase!r}; one of {', '.join(PHASES)}")
        return phase

    @property
    def phase(self) -> str:
        return self._phase

    def enter(self, phase: str) -> None:
        now = self._clock()
        self._totals[self._phase] += now - self._since
        self._phase, self._since = self._checked(phase), now

    def totals_s(self) -> dict[str, float]:
        """Seconds per phase up to now (the running phase included)."""
        totals = dict(self._totals)
        totals[self._phase] += self._clock() - self._since
        return totals


def episode_info(totals_s: Mapping[str, float]) -> dict[str, float]:
    """The totals as flat `Episode.info` entries (`worker_playing_s`, ...): info carries scalars only."""
    return {f"{_INFO_PREFIX}{phase}{_INFO_SUFFIX}": round(float(totals_s[phase]), 3) for phase in PHASES}


def from_episode_info(info: Mapping[str, object]) -> dict[str, float] | None:
    """The totals an episode carried, or None for an episode without them (an older worker, a test's episode)."""
    keys = {phase: f"{_INFO_PREFIX}{phase}{_INFO_SUFFIX}" for phase in PHASES}
    if not all(key in info for key in keys.values()):
        return None
    return {phase: float(info[key]) for phase, key in keys.items()}  # type: ignore[arg-type]
