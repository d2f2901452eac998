"""`python -m benchmarks throughput`'s arithmetic over the trainer's iteration records (the run itself is a benchmark)."""

import click
import pytest

from benchmarks.throughput import policy_forward_cpu_ms, ratio_ceilings, system_rates


def test_rates_leave_out_the_first_iteration_and_split_the_wall_time():
    records = [
        {"env_steps_total": 500, "experience_steps_per_s": 50.0, "elapsed_s": 100.0, "update_s": 5.0},
        {"env_steps_total": 1500, "experience_steps_per_s": 200.0, "elapsed_s": 120.0, "update_s": 10.0},
        {"env_steps_total": 2100, "experience_steps_per_s": 100.0, "elapsed_s": 140.0, "update_s": 10.0},
    ]
    rates = system_rates(records)
    assert rates["steps_measured"] == 1600  # 1000 + 600: iteration 0 (start-up) is left out
    assert rates["experience_steps_per_s"] == pytest.approx(1600 / (5.0 + 6.0))
    assert rates["end_to_end_steps_per_s"] == pytest.approx(1600 / 40.0)
    assert rates["rollout_share_of_wall"] == pytest.approx(11.0 / 40.0)
    assert rates["update_share_of_wall"] == pytest.approx(20.0 / 40.0)


def test_one_iteration_is_not_enough_to_measure():
    with pytest.raises(click.ClickException, match="fewer than 2 iterations"):
        system_rates([{"env_steps_total": 500, "experience_steps_per_s": 50.0, "elapsed_s": 100.0}])


def test_the_policy_forward_pass_is_timed_at_the_workers_batch():
    cpu_ms = policy_forward_cpu_ms(envs_per_worker=3, frames=6)
    assert 0.0 < cpu_ms < 1e4


def test_the_ceilings_add_the_policy_then_the_env_code_to_the_bounds_cpu_per_step():
    ceilings = ratio_ceilings(1.5, {"policy_forward_cpu_ms_per_frame": 1.0, "env_code_cpu_ms_per_step": 0.5})
    assert ceilings == {"ratio_ceiling_raw_plus_policy": 0.6, "ratio_ceiling_env_plus_policy": 0.5}
