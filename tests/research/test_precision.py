"""research/precision learns in one deterministic process: the same seed gives the same episodes and figures."""

from __future__ import annotations

import json

import pytest
from click.testing import CliRunner

from research.precision.learn_to_lap import precision_command


def _run(data) -> dict:
    arguments = ["--data", str(data), "--precision", "fp32", "--seed", "0", "--max-iterations", "1"]
    result = CliRunner().invoke(precision_command, arguments)
    assert result.exit_code == 0, result.output
    return json.loads([line for line in result.stdout.splitlines() if line.startswith("{")][-1])


@pytest.mark.slow
def test_one_iteration_reports_the_steps_it_played_and_repeats_exactly(deepracer_data):
    first, second = _run(deepracer_data), _run(deepracer_data)
    run = first["runs"]["fp32"]["0"]
    played = run["env_steps"] if run["env_steps"] is not None else run["env_steps_trained"]
    assert played > 20  # 20 episodes of at least one step each
    assert first["runs"] == second["runs"]  # deterministic: no timing in the loop
