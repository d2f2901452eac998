"""rsl_rl's adaptive learning rate: down by 1.5 above twice the target, up by 1.5 below half of it, within bounds."""

import pytest

from racer.trainer.kl_adaptive_lr import MAX_LEARNING_RATE, MIN_LEARNING_RATE, KLAdaptiveRate

RULE = KLAdaptiveRate(desired_kl=0.01)


@pytest.mark.parametrize(
    ("kl", "expected"),
    [
        (0.03, 2e-4),  # above 2 x target: / 1.5
        (0.02, 3e-4),  # at 2 x target: kept
        (0.01, 3e-4),  # on target: kept
        (0.005, 3e-4),  # at target / 2: kept
        (0.004, 4.5e-4),  # below target / 2: x 1.5
        (0.0, 3e-4),  # no KL yet (the update's first minibatch): kept
    ],
)
def test_the_rate_follows_the_kl(kl, expected):
    assert RULE.next_rate(3e-4, kl) == pytest.approx(expected)


def test_the_rate_stays_within_its_bounds():
    assert RULE.next_rate(MAX_LEARNING_RATE, 1e-6) == MAX_LEARNING_RATE
    assert RULE.next_rate(MIN_LEARNING_RATE, 1.0) == MIN_LEARNING_RATE
