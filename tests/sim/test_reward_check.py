"""`racer reward test`: real reward functions pass under the race type they were written for; broken ones are named
with file and line (racer.reward.check)."""

from __future__ import annotations

import time

import pytest
from click.testing import CliRunner

from racer.reward.check import check_reward_file
from racer.reward.cli import reward_group
from racer.shared.sim.tracks.track import Track

OBJECT_REWARD = "dpr401_object_avoidance_head_to_head.py"
PLACEHOLDER = "awsdoc_input_example_1.py"
"""The developer guide's `reward = ...` template: float(Ellipsis) raises in every race type."""


@pytest.fixture
def track(deepracer_data, monkeypatch, tmp_path):
    monkeypatch.setenv("RACER_ROUTES_PATH", str(deepracer_data / "routes"))
    monkeypatch.setenv("RACER_DATA_HOME", str(tmp_path / "home"))
    return Track.load("reInvent2019_track")


def _rewards(deepracer_data):
    return sorted((deepracer_data / "reward_functions").glob("*.py"))


def test_every_shared_reward_function_passes_under_its_race_type(deepracer_data, track):
    for path in _rewards(deepracer_data):
        if path.name == PLACEHOLDER:
            continue
        race_types = ("OBJECT_AVOIDANCE", "HEAD_TO_BOT") if path.name == OBJECT_REWARD else ("TIME_TRIAL",)
        for race_type in race_types:
            report = check_reward_file(path, track, race_type)
            assert report.ok, report.format()
            assert report.complete and report.calls > 1000
            expected_warnings = 1 if path.name == "analysis_reward_sample.py" else 0  # `from time import time`
            assert len(report.warnings) == expected_warnings, report.format()


def test_the_object_avoidance_reward_raises_in_a_time_trial_and_the_template_everywhere(deepracer_data, track):
    report = check_reward_file(deepracer_data / "reward_functions" / OBJECT_REWARD, track, "TIME_TRIAL")
    [error] = report.errors
    assert (error.line, error.file) == (29, str(deepracer_data / "reward_functions" / OBJECT_REWARD))
    assert "IndexError" in error.message and error.params["objects_distance"] == []
    template = check_reward_file(deepracer_data / "reward_functions" / PLACEHOLDER, track, "TIME_TRIAL")
    assert [(e.line, "TypeError" in e.message) for e in template.errors] == [(5, True)]


BROKEN = {
    "raises_off_track.py": (
        "def reward_function(params):\n"
        "    width = params['track_width']\n"
        "    if params['is_offtrack']:\n"
        "        return 1.0 / (params['all_wheels_on_track'] * 0)\n"
        "    return width\n",
        4,
        "ZeroDivisionError",
    ),
    "nan.py": (
        "import math\n\ndef reward_function(params):\n    if params['is_reversed']:\n        return math.nan\n    return 1.0\n",
        5,
        "finite",
    ),
    "text.py": (
        "def reward_function(params):\n"
        "    if params['heading'] > 90:\n"
        "        return 'fast'\n"
        "    return '1.5'\n",  # a numeric string is a reward: float('1.5')
        3,
        "must be a number",
    ),
    "huge.py": ("def reward_function(params):\n    return 1e6 * params['speed']\n", 2, "within"),
    "helper_raises.py": (
        "def helper(p):\n"
        "    return p['objects_location'][0]\n"
        "\n"
        "def reward_function(params):\n"
        "    if params['steering_angle'] > 20:\n"
        "        helper(params)\n"
        "    return 1.0\n",
        2,
        "IndexError",
    ),
}


@pytest.mark.parametrize("name", sorted(BROKEN))
def test_a_broken_reward_is_named_with_file_and_line(name, track, tmp_path):
    source, line, words = BROKEN[name]
    path = tmp_path / name
    path.write_text(source)
    report = check_reward_file(path, track)
    assert not report.ok
    [error] = report.errors
    assert (error.file, error.line) == (str(path), line), report.format()
    assert words in error.message and error.params is not None
    assert f"{path}:{line}:" in report.format()


@pytest.mark.serial  # asserts a wall-time bound
def test_slow_and_forbidden_rewards(track, tmp_path):
    slow = tmp_path / "slow.py"
    slow.write_text("import time\n\ndef reward_function(params):\n    time.sleep(0.002)\n    return 1.0\n")
    start = time.perf_counter()
    report = check_reward_file(slow, track, time_budget_s=1.0)
    assert time.perf_counter() - start < 3.0
    assert any("took longer than 1 s" in e.message for e in report.errors), report.format()
    assert [(w.line, "imports time" in w.message) for w in report.warnings] == [(1, True)]
    sluggish = tmp_path / "sluggish.py"
    sluggish.write_text("import time\n\ndef reward_function(params):\n    time.sleep(0.0012)\n    return 1.0\n")
    assert any("slow:" in e.message for e in check_reward_file(sluggish, track, time_budget_s=8.0).errors)
    forbidden = tmp_path / "forbidden.py"
    forbidden.write_text(
        "import os\nfrom subprocess import run\nimport numpy as np\n\n"
        "def reward_function(params):\n    eval('1')\n    return float(np.float64(1.0))\n"
    )
    report = check_reward_file(forbidden, track)
    assert report.ok  # warnings only: racer runs it, DeepRacer on AWS would refuse it
    assert [w.line for w in report.warnings] == [1, 2, 6]
    assert "calls eval()" in report.warnings[2].message


def test_a_reward_that_cannot_load_is_an_error_with_its_line(track, tmp_path):
    path = tmp_path / "syntax.py"
    path.write_text("def reward_function(params):\n    return (\n")
    report = check_reward_file(path, track)
    assert not report.ok and f"{path}:" in report.errors[0].message


@pytest.mark.serial  # asserts a wall-time bound
def test_the_command_exits_1_on_errors_plots_and_stays_under_10_s(deepracer_data, track, tmp_path):
    runner = CliRunner()
    plot = tmp_path / "reward.png"
    start = time.perf_counter()
    good = runner.invoke(
        reward_group,
        [
            "test",
            str(deepracer_data / "reward_functions" / OBJECT_REWARD),
            "--track",
            "reInvent2019_track",
            "--race-type",
            "object_avoidance",
            "--model-metadata",
            str(deepracer_data / "config" / "dpr401_model_metadata_front_shallow_continuous_ppo.json"),
            "--plot",
            str(plot),
        ],
    )
    assert time.perf_counter() - start < 10.0
    assert good.exit_code == 0, good.output
    assert plot.stat().st_size > 10_000 and "OK in" in good.output
    bad = runner.invoke(
        reward_group,
        ["test", str(deepracer_data / "reward_functions" / OBJECT_REWARD), "--track", "reInvent2019_track"],
    )
    assert bad.exit_code == 1 and f"{OBJECT_REWARD}:29: raised IndexError" in bad.output, bad.output
