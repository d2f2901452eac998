"""Where a training run's wall time went, from its iterations log: the trainer's share updating and waiting for
episodes, the workers' shares simulating (training episodes, evaluations), waiting for a checkpoint and loading it,
and how busy the cores were. A bench prints these so the next speed-up is chosen from a measurement.

The trainer's figures are each iteration's `update_s` (the learner's update) and `rollout_s` (from announcing a
checkpoint until its last episode arrived: the trainer waits), against its `elapsed_s` at the last iteration; what is
left is set-up, checkpoints and summaries. The workers' are the phase totals each one sent with its latest episode
(racer.shared.worker_phases), added over the workers.
"""

from __future__ import annotations

from collections.abc import Sequence

from racer.shared.worker_phases import EVALUATING, LOADING, PHASES, PLAYING, STARTING, WAITING

WORKER_SHARE_NAMES = {
    PLAYING: "simulating_training_episodes",
    EVALUATING: "simulating_evaluations",
    WAITING: "waiting_for_a_checkpoint",
    LOADING: "loading_checkpoints",
    STARTING: "starting",
}


def trainer_shares(records: Sequence[dict]) -> dict | None:
    """The trainer's wall time by what it did, as fractions of its elapsed time at the last iteration."""
    if not records:
        return None
    elapsed_s = float(records[-1]["elapsed_s"])
    updating_s = sum(float(r.get("update_s", 0.0)) for r in records)
    waiting_s = sum(float(r.get("rollout_s", 0.0)) for r in records)
    return {
        "wall_s": round(elapsed_s, 1),
        "updating": _share(updating_s, elapsed_s),
        "waiting_for_episodes": _share(waiting_s, elapsed_s),
        "other": _share(max(elapsed_s - updating_s - waiting_s, 0.0), elapsed_s),
    }


def worker_shares(records: Sequence[dict]) -> dict | None:
    """The workers' wall time by phase, added over the workers (each one's totals at its latest episode)."""
    latest: dict[str, dict[str, float]] = {}
    for record in records:
        latest.update(record.get("worker_phases_s") or {})
    if not latest:
        return None
    totals = {phase: sum(worker.get(phase, 0.0) for worker in latest.values()) for phase in PHASES}
    wall_s = sum(totals.values())
    return {
        "workers": len(latest),
        "wall_s": round(wall_s, 1),
        **{WORKER_SHARE_NAMES[phase]: _share(totals[phase], wall_s) for phase in PHASES},
    }


def time_shares(records: Sequence[dict], cpu_s: float, wall_s: float, cores: int) -> dict:
    """Trainer, workers, and the cores' use (the run's processes' CPU seconds over cores × wall seconds)."""
    return {
        "trainer": trainer_shares(records),
        "workers": worker_shares(records),
        "cpu_busy": _share(cpu_s, cores * wall_s),
    }


def _share(part: float, whole: float) -> float | None:
    return round(part / whole, 3) if whole > 0 else None
