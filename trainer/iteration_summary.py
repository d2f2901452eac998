"""The summary of one training iteration: what its episodes scored, overall and per world, and how fast experience
came in; recorded as one JSON line of the run's iterations log in the store and published on the `iterations`
stream (the viewer and the analysis read them). The trainer adds `progress`, how far the run is and how long it has
left (racer.shared.run_progress), which `racer train` prints and the viewer shows."""

from __future__ import annotations

import json
from collections import defaultdict
from collections.abc import Sequence

import numpy as np

from racer.shared.episode import Episode
from racer.shared.model_layout import ModelLayout
from racer.shared.store import ObjectNotFoundError, ObjectStore
from racer.shared.worker_phases import from_episode_info


def world_steps_per_s(episodes: list[Episode]) -> float:
    """Experience rate of one world: the rates its workers measured while playing their shares, added up."""
    by_worker = {e.worker_id: float(e.info.get("rollout_steps_per_s", 0.0)) for e in episodes}
    return round(sum(by_worker.values()), 1)


def worker_phases_s(episodes: list[Episode]) -> dict[str, dict[str, float]]:
    """Each worker's wall seconds per phase since it started (racer.shared.worker_phases), as its latest episode of the
    iteration carried them: where the workers' time went, kept in the iterations log."""
    latest: dict[str, dict[str, float]] = {}
    for episode in episodes:
        totals = from_episode_info(episode.info)
        key = str(episode.worker_id)
        if totals is not None and sum(totals.values()) >= sum(latest.get(key, {}).values()):
            latest[key] = totals
    return dict(sorted(latest.items()))


def _scores(episodes: list[Episode]) -> dict:
    return {
        "mean_reward": float(np.mean([e.total_reward for e in episodes])),
        "mean_progress": float(np.mean([e.progress for e in episodes])),
        "completion_rate": float(np.mean([e.final_status == "lap_complete" for e in episodes])),
    }


def iteration_summary(
    iteration: int, episodes: list[Episode], env_steps_total: int, rollout_wall_s: float, elapsed_s: float
) -> dict:
    """The iteration's scores and rates over the episodes it trains on, overall and per world."""
    by_world = defaultdict(list)
    for episode in episodes:
        by_world[episode.world].append(episode)
    steps = sum(e.steps for e in episodes)
    return {
        "iteration": iteration,
        "episodes": len(episodes),
        "env_steps_total": env_steps_total,
        **_scores(episodes),
        "experience_steps_per_s": steps / max(rollout_wall_s, 1e-6),
        "elapsed_s": elapsed_s,
        "worker_phases_s": worker_phases_s(episodes),
        "worlds": {
            world: {"episodes": len(items), **_scores(items), "steps_per_s": world_steps_per_s(items)}
            for world, items in by_world.items()
        },
    }


def update_summary(stats: Sequence[object]) -> dict:
    """The update's clip fraction and KL (means over its epochs; None for a learner that reports neither, SAC)."""

    def mean(name: str) -> float | None:
        values = [getattr(entry, name) for entry in stats if hasattr(entry, name)]
        return round(sum(values) / len(values), 6) if values else None

    return {"clip_fraction": mean("clip_fraction"), "kl_divergence": mean("kl_divergence")}


def overlap_summary(iteration: int, episodes: list[Episode]) -> dict:
    """An overlapped run's iteration: the share of its episodes played by the checkpoint before the network's."""
    behind = sum(1 for episode in episodes if episode.policy_version < iteration)
    return {"episodes_one_behind_share": round(behind / len(episodes), 4) if episodes else 0.0}


def append_to_log(store: ObjectStore, layout: ModelLayout, summary: dict) -> None:
    """Append the summary to the store's iterations log: the record (the `iterations` stream only feeds displays, and
    the trainer publishes there after this)."""
    key = layout.iterations_log
    try:
        existing = store.get_bytes(key)
    except ObjectNotFoundError:
        existing = b""
    store.put_bytes(key, existing + json.dumps(summary).encode() + b"\n")
