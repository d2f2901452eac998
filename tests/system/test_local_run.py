"""`racer train`, the embedded default: it runs everything as local processes and leaves nothing behind.

A run to its episode limit is tests/system/test_object_avoidance_training.py's; a stop by signal (SIGINT and SIGTERM
share racer train's handler) is tests/system/test_redis_resilience.py's, with Redis hung, and the viewer tests stop
their runs with SIGINT."""

from __future__ import annotations

import os
import subprocess
import time
from pathlib import Path

import pytest

from tests.conftest import write_custom_files
from tests.short_runs import train_args, train_env

pytestmark = [pytest.mark.slow, pytest.mark.heavy]  # trainers and workers as processes


def processes_mentioning(text: str) -> list[str]:
    """Live processes whose command line or environment mentions `text` (our temp folder), except this one."""
    found = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit() or int(entry.name) == os.getpid():
            continue
        try:
            cmdline = (entry / "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
            environ = (entry / "environ").read_bytes().decode(errors="replace")
            state = (entry / "stat").read_text().split()[2]
        except (FileNotFoundError, ProcessLookupError, PermissionError):
            continue
        if (text in cmdline or text in environ) and state != "Z":
            found.append(cmdline)
    return found


@pytest.fixture
def small_custom_files(tmp_path: Path) -> Path:
    return write_custom_files(tmp_path / "custom_files")


def racer_train(tmp_path: Path, custom_files: Path, *args: str) -> subprocess.Popen:
    return subprocess.Popen(
        train_args(custom_files, "local-model", *args),
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        env=train_env(tmp_path / "store"),
        cwd=tmp_path,
    )


def test_a_reward_that_raises_during_training_stops_the_run_with_its_file_line_and_params(tmp_path, small_custom_files):
    """The SimApp's RewardFunctionError ends its job; racer stops the run (no worker restarted in a loop) and says
    where the user's code failed and on which params, and the run's exit status says it failed."""
    (small_custom_files / "reward_function.py").write_text(
        "calls = 0\n\n\n"
        "def reward_function(params):\n"
        "    global calls\n"
        "    calls += 1\n"
        "    if calls > 400:  # past the preflight's 352 calls; a worker's own (50 an iteration): some iterations train\n"
        "        return params['objects_location'][0][0]\n"
        "    return 1.0\n"
    )
    process = racer_train(tmp_path, small_custom_files, "--max-minutes", "8", "--viewer-port", "0")
    output, _ = process.communicate(timeout=900)
    assert process.returncode == 3, output[-4000:]
    assert "the run stopped" in output and 'reward_function.py", line 8' in output, output[-4000:]
    assert "IndexError" in output and "with params x=" in output, output[-4000:]
    assert "restarting it" not in output, output[-4000:]
    time.sleep(1)
    assert processes_mentioning(str(tmp_path)) == []
