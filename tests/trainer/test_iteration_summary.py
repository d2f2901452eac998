"""The iteration summary (racer.trainer.iteration_summary): scores and experience rates, overall and per world."""

from __future__ import annotations

import pytest

from racer.shared import worker_phases
from racer.shared.worker_phases import PhaseClock
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


def test_the_summary_keeps_each_workers_latest_phase_times():
    """Where the workers' time went (racer.shared.worker_phases): each worker's totals from its latest episode, in
    whatever order the episodes came; an episode without them (an older worker) adds nothing."""
    now = [0.0]
    phases = PhaseClock(clock=lambda: now[0])
    now[0] = 2.0
    phases.enter(worker_phases.WAITING)
    now[0] = 5.0
    phases.enter(worker_phases.PLAYING)
    now[0] = 9.0
    early = phases.totals_s()
    now[0] = 12.0
    later = phases.totals_s()
    assert later == {**dict.fromkeys(worker_phases.PHASES, 0.0), "starting": 2.0, "waiting": 3.0, "playing": 7.0}
    assert early["playing"] == 4.0
    episodes = [make_episode(10, seed=seed, worker_id=worker_id) for seed, worker_id in enumerate((0, 0, 1))]
    episodes[0].info.update(worker_phases.episode_info(later))
    episodes[1].info.update(worker_phases.episode_info(early))
    summary = iteration_summary(0, episodes, env_steps_total=30, rollout_wall_s=2.0, elapsed_s=0.0)
    assert summary["worker_phases_s"] == {"0": later}
    assert worker_phases.from_episode_info(episodes[2].info) is None
    with pytest.raises(ValueError, match="unknown worker phase 'napping'"):
        phases.enter("napping")
