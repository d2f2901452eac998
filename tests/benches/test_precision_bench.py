"""`racer bench precision` learns in one deterministic process: the same seed gives the same episodes and figures."""

from __future__ import annotations

import json

import pytest
from click.testing import CliRunner

from racer.benches.precision import precision_bench_command


def _run() -> dict:
    result = CliRunner().invoke(
        precision_bench_command, ["--precision", "fp32", "--seed", "0", "--max-iterations", "1"]
    )
    assert result.exit_code == 0, result.output
    return json.loads([line for line in result.stdout.splitlines() if line.startswith("{")][-1])


@pytest.mark.slow
def test_one_iteration_reports_the_steps_it_played_and_repeats_exactly():
    first, second = _run(), _run()
    run = first["runs"]["fp32"]["0"]
    played = run["env_steps"] if run["env_steps"] is not None else run["env_steps_trained"]
    assert played > 20  # 20 episodes of at least one step each
    assert first["runs"] == second["runs"]  # deterministic: no timing in the loop
