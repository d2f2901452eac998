"""The iteration summary (racer.trainer.iteration_summary): scores and experience rates, overall and per world."""

from __future__ import annotations

from racer.trainer.iteration_summary import iteration_summary
from tests.conftest import make_episode


def test_the_iteration_summary_has_each_worlds_experience_rate():
    """The viewer's steps/s curve per world: the rates the world's workers measured while playing, added up."""
    played = [(0, "base", 100.0), (0, "base", 100.0), (1, "carpet", 40.0), (2, "carpet", 60.5)]
    episodes = []
    for seed, (worker_id, world, rate) in enumerate(played):
        episode = make_episode(10, seed=seed, worker_id=worker_id, world=world)
        episode.info["rollout_steps_per_s"] = rate
        episodes.append(episode)
    summary = iteration_summary(0, episodes, env_steps_total=40, rollout_wall_s=2.0, elapsed_s=0.0)
    assert summary["worlds"]["base"]["steps_per_s"] == 100.0  # one worker, not counted once per episode
    assert summary["worlds"]["carpet"]["steps_per_s"] == 100.5
    assert summary["experience_steps_per_s"] == 40 / 2.0
    assert summary["episodes"] == 4 and summary["env_steps_total"] == 40
