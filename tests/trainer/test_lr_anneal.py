"""The annealed learning rate: the share of the run used, and the rate it leaves."""

import pytest

from racer.shared.run_progress import StopCondition
from racer.trainer.lr_anneal import annealed_rate, share_of_run_used


def test_the_sooner_limit_sets_the_share_used():
    condition = StopCondition(max_episodes=1000, max_minutes=20.0)
    assert share_of_run_used(condition, elapsed_s=300.0, episodes=100) == pytest.approx(0.25)  # the clock's quarter
    assert share_of_run_used(condition, elapsed_s=60.0, episodes=500) == pytest.approx(0.5)  # half the episodes
    assert share_of_run_used(StopCondition(max_episodes=200), elapsed_s=1e6, episodes=50) == pytest.approx(0.25)
    assert share_of_run_used(condition, elapsed_s=1300.0, episodes=10) == 1.0  # past the limit: used up


def test_the_rate_falls_linearly_to_zero_at_the_end():
    assert annealed_rate(3e-4, 0.0) == 3e-4
    assert annealed_rate(3e-4, 0.75) == pytest.approx(7.5e-5)
    assert annealed_rate(3e-4, 1.0) == 0.0
    assert annealed_rate(3e-4, 1.5) == 0.0
