"""`racer train`, the embedded default: it runs everything as local processes and leaves nothing behind."""

from __future__ import annotations

import os
import signal
import subprocess
import time
from pathlib import Path

import pytest

from racer.shared.policy.checkpoints import CheckpointStore
from racer.shared.store import LocalStore
from tests.conftest import write_custom_files
from tests.short_runs import train_args, train_env

pytestmark = [pytest.mark.slow, pytest.mark.serial]  # they time their own processes


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


def test_train_runs_to_the_episode_limit_and_cleans_up(tmp_path, small_custom_files):
    process = racer_train(tmp_path, small_custom_files, "--max-episodes", "4")
    output, _ = process.communicate(timeout=600)
    assert process.returncode == 0, output[-4000:]
    assert "iteration   0" in output and "iteration   1" in output, output[-3000:]
    model = tmp_path / "store" / "local-model" / "model"
    assert (model / ".coach_checkpoint").read_text().startswith("2_Step-")
    assert (model / ".finished").is_file()
    time.sleep(1)
    assert processes_mentioning(str(tmp_path)) == []


def test_ctrl_c_writes_a_final_checkpoint_and_leaves_no_process(tmp_path, small_custom_files):
    process = racer_train(tmp_path, small_custom_files, "--max-episodes", "1000")
    model = tmp_path / "store" / "local-model" / "model"
    deadline = time.monotonic() + 300
    while time.monotonic() < deadline and not (model / ".coach_checkpoint").is_file():
        time.sleep(0.5)
    assert (model / ".coach_checkpoint").is_file(), "training never wrote checkpoint 0"
    time.sleep(3)
    process.send_signal(signal.SIGINT)
    output, _ = process.communicate(timeout=180)
    assert process.returncode == 0, output[-4000:]
    assert (model / ".finished").is_file()
    # The pointer names the final checkpoint, complete and loadable (the run's last weights).
    checkpoints = CheckpointStore(LocalStore(tmp_path / "store"), "local-model")
    final = checkpoints.latest_name()
    checkpoints.load_policy(final)
    trainer_log = (tmp_path / "store" / ".runs" / "local-model" / "trainer.log").read_text()
    number = final.split("_")[0]
    assert f"Training finished at checkpoint {number} " in trainer_log
    time.sleep(1)
    assert processes_mentioning(str(tmp_path)) == [], output[-2000:]


def test_a_reward_that_raises_during_training_stops_the_run_with_its_file_line_and_params(tmp_path, small_custom_files):
    """The SimApp's RewardFunctionError ends its job; racer stops the run (no worker restarted in a loop) and says
    where the user's code failed and on which params, and the run's exit status says it failed."""
    (small_custom_files / "reward_function.py").write_text(
        "calls = 0\n\n\n"
        "def reward_function(params):\n"
        "    global calls\n"
        "    calls += 1\n"
        "    if calls > 1500:  # well after the preflight's calls: the first iterations train\n"
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
