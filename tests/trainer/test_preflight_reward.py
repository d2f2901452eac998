"""Preflight runs a short `racer reward test`: a reward that raises on params DeepRacer produces is refused before
anything starts; a slow one or one DeepRacer on AWS would reject is a warning."""

from __future__ import annotations

import pytest

from racer.shared.run_settings import RunOptions
from racer.shared.user_errors import RunConfigError
from racer.trainer.preflight import preflight
from tests.conftest import write_custom_files

RAISES_OFF_TRACK = """def reward_function(params):
    if not params["all_wheels_on_track"]:
        raise ValueError("off track")
    return 1.0
"""


def test_a_reward_that_raises_off_track_is_refused_with_its_line(tmp_path):
    custom = write_custom_files(tmp_path / "custom", reward_source=RAISES_OFF_TRACK)
    with pytest.raises(RunConfigError) as info:
        preflight(custom, RunOptions(1, "racer_oval", ("base",)))
    message = str(info.value)
    assert f"{custom / 'reward_function.py'}:3: raised ValueError: off track" in message
    assert "racer reward test" in message


def test_a_reward_deepracer_on_aws_would_reject_is_a_warning(tmp_path):
    source = "import os\n\ndef reward_function(params):\n    return 1.0\n"
    custom = write_custom_files(tmp_path / "custom", reward_source=source)
    report = preflight(custom, RunOptions(1, "racer_oval", ("base",)))
    assert any("imports os" in warning for warning in report.warnings), report.warnings
