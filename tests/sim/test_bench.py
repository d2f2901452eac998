"""`racer bench sim` prints one JSON line with the three documented keys (speed itself is not asserted)."""

from __future__ import annotations

import json

from click.testing import CliRunner

from racer.shared.sim.bench import sim_bench_command


def test_bench_prints_one_json_line():
    result = CliRunner().invoke(sim_bench_command, ["--steps", "60"])
    assert result.exit_code == 0, result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 1
    numbers = json.loads(lines[0])
    assert {"env_steps_per_s", "raw_bound_steps_per_s", "ratio"} <= set(numbers)
    assert numbers["env_steps_per_s"] > 0 and numbers["raw_bound_steps_per_s"] > 0
    assert abs(numbers["ratio"] - numbers["env_steps_per_s"] / numbers["raw_bound_steps_per_s"]) < 0.01
