"""`python -m benchmarks throughput`: its arithmetic over the trainer's iteration records, and one tiny real run of
both modes (Redis, a worker, the trainer)."""

import json
import tempfile

import click
import pytest
from click.testing import CliRunner

from benchmarks.throughput import policy_forward_cpu_ms, ratio_ceilings, throughput_bench_command, worker_counts
from benchmarks.throughput_modes import CpuMark, cpu_window, system_rates
from benchmarks.time_shares import trainer_shares
from tests.conftest import write_custom_files


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


def test_the_trainers_other_time_is_broken_down_by_its_timers_after_the_first_iteration():
    def record(elapsed_s, on_path, while_collecting):
        parts = {"on_path": on_path, "while_collecting": while_collecting}
        return {"elapsed_s": elapsed_s, "update_s": 5.0, "rollout_s": 10.0, "trainer_parts_s": parts}

    records = [
        record(30.0, {"onnx_export": 3.0}, {}),  # set-up and iteration 0: left out
        record(50.0, {"onnx_export": 4.0, "retention": 1.0}, {"iterations_log_write": 2.0}),
    ]
    shares = trainer_shares(records, after_first=True)
    assert shares["wall_s"] == 20.0 and shares["updating"] == 0.25
    assert shares["waiting_for_episodes"] == 0.4  # 10 s collecting less the 2 s of records written meanwhile
    assert shares["other"] == 0.25  # 20 - 5 - 10
    assert shares["other_breakdown"] == {"onnx_export": 0.05, "retention": 0.05, "unaccounted": 0.15}
    assert shares["while_collecting"] == {"iterations_log_write": 0.1}


def test_cpu_busy_is_measured_from_the_first_iterations_line_to_the_last():
    marks = [CpuMark(1, 10.0, 5.0), CpuMark(2, 20.0, 20.0), CpuMark(3, 30.0, 41.0)]
    assert cpu_window(marks, records=3) == (36.0, 20.0)
    with pytest.raises(click.ClickException, match="not seen arriving"):
        cpu_window(marks[:2], records=3)


def test_worker_counts_are_a_comma_list_each_once():
    assert worker_counts(None, None, "1,2,4") == (1, 2, 4)
    for bad in ("1,x", "0", "2,2", "33"):
        with pytest.raises(click.BadParameter):
            worker_counts(None, None, bad)


def test_the_policy_forward_pass_is_timed_at_the_workers_batch():
    cpu_ms = policy_forward_cpu_ms(envs_per_worker=3, frames=6)
    assert 0.0 < cpu_ms < 1e4


def test_the_ceilings_add_the_policy_then_the_env_code_to_the_bounds_cpu_per_step():
    ceilings = ratio_ceilings(1.5, {"policy_forward_cpu_ms_per_frame": 1.0, "env_code_cpu_ms_per_step": 0.5})
    assert ceilings == {"ratio_ceiling_raw_plus_policy": 0.6, "ratio_ceiling_env_plus_policy": 0.5}


@pytest.mark.slow
def test_a_tiny_run_of_both_modes_prints_each_modes_rate_cpu_busy_and_time_shares(tmp_path, monkeypatch):
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    custom = write_custom_files(tmp_path / "custom_files")
    args = ["--custom-files", str(custom), "--iterations", "3", "--workers", "1", "--envs", "1"]
    result = CliRunner().invoke(throughput_bench_command, [*args, "--bound-seconds", "0", "--device", "cpu"])
    assert result.exit_code == 0, result.output
    lines = result.stdout.strip().splitlines()
    assert len(lines) == 1  # the runs' progress went to stderr
    line = json.loads(lines[0])
    for mode in ("strict", "overlap"):
        figures = line["modes"][mode]
        assert figures["iterations"] == 3 and figures["end_to_end_env_steps_per_s"] > 0
        assert 0 < figures["cpu_busy"] <= 1
        trainer = figures["time_shares"]["trainer"]
        assert 0 < trainer["updating"] < 1 and "onnx_export" in trainer["other_breakdown"]
        assert "iterations_log_write" in trainer["while_collecting"]  # written while the workers played
    assert line["modes"]["strict"]["episodes_one_behind_share"] == []  # strict trains none behind
    assert max(line["modes"]["overlap"]["episodes_one_behind_share"]) > 0
    assert line["end_to_end_steps_per_s"] == line["modes"]["strict"]["end_to_end_env_steps_per_s"]
    assert "bound_steps_per_s" not in line and "by_workers" not in line
    assert not [p for p in tmp_path.iterdir() if p.name.startswith("racer-throughput-")]  # the runs' folder is gone
