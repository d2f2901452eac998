"""`python -m benchmarks sim` prints one JSON line with the three documented keys (speed itself is not asserted)."""

from __future__ import annotations

import json

from click.testing import CliRunner

from benchmarks.sim import sim_bench_command


def test_bench_prints_one_json_line():
    result = CliRunner().invoke(sim_bench_command, ["--steps", "60"])
    assert result.exit_code == 0, result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 1
    numbers = json.loads(lines[0])
    assert {"env_steps_per_s", "raw_bound_steps_per_s", "ratio"} <= set(numbers)
    assert numbers["env_steps_per_s"] > 0 and numbers["raw_bound_steps_per_s"] > 0
    assert abs(numbers["ratio"] - numbers["env_steps_per_s"] / numbers["raw_bound_steps_per_s"]) < 0.01
    # The renderer it drew with is named; the suite's MUJOCO_GL overrides the (default) auto choice.
    assert numbers["mujoco_gl"] == "egl" and numbers["gl_renderer"], numbers
    assert ("cpu_renderer" in numbers) != ("llvmpipe" in numbers["gl_renderer"]), numbers


def test_bench_with_obstacles_and_bot_cars_reports_each_beside_the_time_trial():
    result = CliRunner().invoke(sim_bench_command, ["--steps", "60", "--obstacles", "2", "--bot-cars", "1"])
    assert result.exit_code == 0, result.output
    numbers = json.loads(result.output.strip())
    trial = numbers["time_trial_steps_per_s"]
    for name in ("obstacles_2", "bot_cars_1"):
        rate, ratio = numbers[f"{name}_steps_per_s"], numbers[f"{name}_ratio"]
        assert rate > 0, numbers
        # The rates are printed to 0.1 steps/s and the ratio to 0.001: the ratio of the printed rates agrees up to that.
        rounding = (0.05 / rate + 0.05 / trial) * rate / trial + 0.0005
        assert abs(ratio - rate / trial) <= rounding, numbers
        assert 0 < numbers[f"{name}_ratio_median_of_rounds"] < 3 * ratio, numbers
        if abs(ratio - 0.85) > 0.0005:
            assert numbers[f"{name}_goal_met"] == (ratio >= 0.85), numbers
