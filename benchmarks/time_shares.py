"""Where a training run's wall time went, from its iterations log: the trainer's share updating and waiting for
episodes and what its other time was made of, the workers' shares simulating (training episodes, evaluations),
waiting for a checkpoint and loading it, and how busy the cores were. A bench prints these so the next speed-up is
chosen from a measurement.

The trainer's figures are each iteration's `update_s` (the learner's update) and `rollout_s` (from announcing a
checkpoint until its last episode arrived: the trainer waits), against its `elapsed_s` at the last iteration; what is
left is set-up, checkpoints and summaries: `other_breakdown` splits it by the trainer's own timers
(`trainer_parts_s`, racer.trainer.iteration_parts), `unaccounted` being what no timer covers (set-up, DeepRacer's log
lines, Python between the timers). `while_collecting`: the parts the trainer did after an announcement, while the
workers played; they are taken out of `waiting_for_episodes`. The workers' are the phase totals each one sent with
its latest episode (racer.shared.worker_phases), added over the workers.

`after_first`: over the iterations after the first only (from the first iteration's `elapsed_s` to the last's: what
the throughput bench measures, the start-up left out); else from the trainer's start.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from racer.shared.worker_phases import EVALUATING, LOADING, PHASES, PLAYING, STARTING, WAITING

WORKER_SHARE_NAMES = {
    PLAYING: "simulating_training_episodes",
    EVALUATING: "simulating_evaluations",
    WAITING: "waiting_for_a_checkpoint",
    LOADING: "loading_checkpoints",
    STARTING: "starting",
}
ON_PATH, WHILE_COLLECTING = "on_path", "while_collecting"
"""The two buckets of an iteration record's `trainer_parts_s` (racer.trainer.iteration_parts)."""


def trainer_shares(records: Sequence[dict], after_first: bool = False) -> dict | None:
    """The trainer's wall time by what it did, as fractions of its elapsed time at the last iteration."""
    if len(records) < (2 if after_first else 1):
        return None
    counted = records[1:] if after_first else records
    start_s = float(records[0]["elapsed_s"]) if after_first else 0.0
    elapsed_s = float(records[-1]["elapsed_s"]) - start_s
    updating_s = sum(float(r.get("update_s", 0.0)) for r in counted)
    collecting_s = sum(float(r.get("rollout_s", 0.0)) for r in counted)
    other_s = max(elapsed_s - updating_s - collecting_s, 0.0)
    shares = {"wall_s": round(elapsed_s, 1), "updating": _share(updating_s, elapsed_s)}
    if "trainer_parts_s" not in records[-1]:  # a trainer before the part timers
        return shares | {
            "waiting_for_episodes": _share(collecting_s, elapsed_s),
            "other": _share(other_s, elapsed_s),
        }
    on_path = _parts_between(records[0] if after_first else None, records[-1], ON_PATH)
    while_collecting = _parts_between(records[0] if after_first else None, records[-1], WHILE_COLLECTING)
    waiting_s = max(collecting_s - sum(while_collecting.values()), 0.0)
    return shares | {
        "waiting_for_episodes": _share(waiting_s, elapsed_s),
        "other": _share(other_s, elapsed_s),
        "other_breakdown": {
            **{part: _share(s, elapsed_s) for part, s in sorted(on_path.items())},
            "unaccounted": _share(max(other_s - sum(on_path.values()), 0.0), elapsed_s),
        },
        WHILE_COLLECTING: {part: _share(s, elapsed_s) for part, s in sorted(while_collecting.items())},
    }


def _parts_between(first: Mapping | None, last: Mapping, bucket: str) -> dict[str, float]:
    """Seconds per part of one bucket between two records' running totals (`first` None: since the start)."""
    before = (first or {}).get("trainer_parts_s", {}).get(bucket, {})
    return {part: s - before.get(part, 0.0) for part, s in last["trainer_parts_s"].get(bucket, {}).items()}


def worker_shares(records: Sequence[dict], after_first: bool = False) -> dict | None:
    """The workers' wall time by phase, added over the workers (each one's totals at its latest episode; with
    `after_first`, less their totals at the first iteration)."""
    totals = _phase_totals(records)
    if not totals:
        return None
    if after_first:
        before = _phase_totals(records[:1])
        totals = {
            worker: {p: s - before.get(worker, {}).get(p, 0.0) for p, s in t.items()} for worker, t in totals.items()
        }
    added = {phase: sum(worker.get(phase, 0.0) for worker in totals.values()) for phase in PHASES}
    wall_s = sum(added.values())
    return {
        "workers": len(totals),
        "wall_s": round(wall_s, 1),
        **{WORKER_SHARE_NAMES[phase]: _share(added[phase], wall_s) for phase in PHASES},
    }


def _phase_totals(records: Sequence[dict]) -> dict[str, dict[str, float]]:
    latest: dict[str, dict[str, float]] = {}
    for record in records:
        latest.update(record.get("worker_phases_s") or {})
    return latest


def time_shares(records: Sequence[dict], cpu_s: float, wall_s: float, cores: int, after_first: bool = False) -> dict:
    """Trainer, workers, and the cores' use (the run's processes' CPU seconds over cores × wall seconds, in the same
    window as the rest)."""
    return {
        "trainer": trainer_shares(records, after_first),
        "workers": worker_shares(records, after_first),
        "cpu_busy": _share(cpu_s, cores * wall_s),
    }


def _share(part: float, whole: float) -> float | None:
    return round(part / whole, 3) if whole > 0 else None
