"""`racer train` survives its own Redis, and stopping never depends on Redis (issue 15).

Real processes throughout: `racer train` with its redis-server, or a trainer and workers against the fixture's
redis-server, with tiny episodes (2 per iteration on the shortest track) so each scenario takes about a minute.
"""

from __future__ import annotations

import json
import os
import signal
import time
from datetime import datetime
from pathlib import Path

import pytest

from racer.shared.deepracer.simtrace import read_simtrace
from racer.shared.policy.checkpoints import CheckpointStore
from racer.shared.store import LocalStore
from tests.system.test_local_run import processes_mentioning, racer_train

pytestmark = [pytest.mark.slow, pytest.mark.heavy]  # trainers and workers as processes


@pytest.fixture
def small_custom_files(tmp_path: Path) -> Path:
    from tests.conftest import write_custom_files

    return write_custom_files(tmp_path / "custom_files")


def redis_pid(tmp_path: Path) -> int | None:
    """The redis-server `racer train` started for this test: its working folder (--dir) is under tmp_path
    (redis-server rewrites its command line and environment block)."""
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            program = (entry / "cmdline").read_bytes().split(b" ")[0].split(b"\0")[0]
            cwd = os.readlink(entry / "cwd")
            state = (entry / "stat").read_text().split()[2]
        except (FileNotFoundError, ProcessLookupError, PermissionError):
            continue
        if program.endswith(b"redis-server") and cwd.startswith(str(tmp_path)) and state != "Z":
            return int(entry.name)
    return None


def wait_for(condition, timeout_s: float, what: str, output_of=None):
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        value = condition()
        if value:
            return value
        time.sleep(0.2)
    raise AssertionError(f"timed out waiting for {what}" + (f":\n{output_of()}" if output_of else ""))


def newest_checkpoint(model: Path) -> int:
    pointer = model / ".coach_checkpoint"
    return int(pointer.read_text().split("_")[0]) if pointer.is_file() else -1


@pytest.mark.parametrize("mode", ["strict", "overlap"])
def test_kill_9_of_the_embedded_redis_loses_no_episode(tmp_path, mode):
    from tests.conftest import write_custom_files

    # No in-training evaluation: a barely trained greedy policy may circle on the oval, and an evaluation episode
    # then runs to DeepRacer's 100,000-step cap (6 minutes here) while the iteration waits for worker 0.
    custom_files = write_custom_files(tmp_path / "custom_files", min_eval_trials=0)
    process = racer_train(tmp_path, custom_files, "--max-episodes", "8", *(["--overlap"] if mode == "overlap" else []))
    model = tmp_path / "store" / "local-model" / "model"
    try:
        for round_number, checkpoint in enumerate((1, 2)):
            wait_for(lambda c=checkpoint: newest_checkpoint(model) >= c, 300, f"checkpoint {checkpoint}")
            time.sleep(1.5 * round_number)  # the second kill lands later in the iteration (workers playing/pushing)
            victim = redis_pid(tmp_path)
            assert victim is not None
            os.kill(victim, signal.SIGKILL)
            wait_for(lambda v=victim: (redis_pid(tmp_path) or v) != v, 30, "a new redis-server")
        output, _ = process.communicate(timeout=600)
    finally:
        if process.poll() is None:
            process.kill()
    assert process.returncode == 0, output[-4000:]
    assert output.count("Redis is DOWN") == 2 and output.count("Redis is back") == 2, output[-4000:]
    assert newest_checkpoint(model) == 4 and (model / ".finished").is_file()

    # Every iteration trained on exactly its 2 episodes, and they are the ones the workers played and logged:
    # the trainer's step count per iteration equals the steps in that iteration's simtraces.
    store = tmp_path / "store" / "local-model"
    records = [json.loads(line) for line in (store / "metrics" / "iterations.jsonl").read_text().splitlines()]
    assert [r["iteration"] for r in records] == [0, 1, 2, 3]
    assert [(r["episodes"], r["episodes_dropped"]) for r in records] == [(2, 0)] * 4
    assert all(("episodes_one_behind_share" in r) == (mode == "overlap") for r in records)  # --overlap reached it
    previous_total = 0
    for record in records:
        traces = [
            read_simtrace(store / str(worker) / "training-simtrace" / f"{record['iteration']}-iteration.csv")
            for worker in (0, 1)
        ]
        assert [trace.episode.nunique() for trace in traces] == [1, 1]
        assert sum(len(trace) for trace in traces) == record["env_steps_total"] - previous_total
        previous_total = record["env_steps_total"]
    for worker in (0, 1):  # each worker's training episodes counted once each, none missing, none twice
        name = "TrainingMetrics.json" if worker == 0 else f"TrainingMetrics_{worker}.json"
        metrics = json.loads((store / "metrics" / name).read_text())["metrics"]
        assert [m["episode"] for m in metrics if m["phase"] == "training"] == [1, 2, 3, 4]
    time.sleep(1)
    assert processes_mentioning(str(tmp_path)) == []


def test_sigterm_with_redis_hung_stops_everything_within_30_s(tmp_path, small_custom_files):
    """A stopped (SIGSTOP) redis-server: alive, so nobody restarts it, and it answers nothing. Also what Ctrl-C does
    (racer train handles SIGINT and SIGTERM alike): the final checkpoint, .finished, no process left."""
    process = racer_train(tmp_path, small_custom_files, "--max-episodes", "1000")
    model = tmp_path / "store" / "local-model" / "model"
    try:
        wait_for(lambda: newest_checkpoint(model) >= 1, 300, "checkpoint 1")
        victim = redis_pid(tmp_path)
        os.kill(victim, signal.SIGSTOP)
        time.sleep(3)  # every client is now blocked on it
        started = time.monotonic()
        process.send_signal(signal.SIGTERM)
        output, _ = process.communicate(timeout=60)
        stopped_s = time.monotonic() - started
    finally:
        if process.poll() is None:
            process.kill()
    assert stopped_s < 30, f"took {stopped_s:.1f} s:\n{output[-3000:]}"
    assert process.returncode == 0, output[-4000:]
    assert processes_mentioning(str(tmp_path)) == []
    assert (model / ".finished").is_file()
    checkpoints = CheckpointStore(LocalStore(tmp_path / "store"), "local-model")
    final = checkpoints.latest_name()
    checkpoints.load_policy(final)  # the pointer names the final checkpoint, complete and loadable
    trainer_log = (tmp_path / "store" / ".runs" / "local-model" / "trainer.log").read_text()
    assert f"Training finished at checkpoint {final.split('_')[0]} " in trainer_log


def test_with_redis_dead_the_trainer_honours_max_minutes_and_workers_stop_on_sigterm(
    redis_server, tmp_path, small_custom_files
):
    """docker compose's case: Redis is gone for good and nobody restarts it."""
    from racer.shared.config import LocalStoreSettings, RedisSettings, ServiceSettings
    from racer.shared.redis_connection import RedisLink
    from racer.shared.transport.channels import RunChannel
    from tests.system.test_distributed_training import SystemRun

    settings = ServiceSettings(
        redis=RedisSettings(url=redis_server.url, connect_timeout_s=10),
        store=LocalStoreSettings(root=tmp_path / "store"),
    )
    run = SystemRun(settings, "dead-redis", small_custom_files, tmp_path / "logs")
    try:
        # One minute (counted from the trainer's start, after its imports): the set-up below takes about 18 s on a
        # quiet 2-core machine and 40 s at load average 8, so Redis dies well before the limit fires, which the test
        # checks below; a longer limit would only add idle time.
        trainer = run.start_trainer(1000, "--max-minutes", "1")
        workers = [run.start_worker(0), run.start_worker(1)]
        channel = RunChannel(RedisLink(settings.redis), run.prefix)
        model = tmp_path / "store" / run.prefix / "model"
        wait_for(
            lambda: set(channel.live_workers()) == {0, 1} and newest_checkpoint(model) >= 0,
            100,
            "checkpoint 0 and both workers' heartbeats",
            lambda: run.log_text("trainer")[-2000:],
        )
        redis_server.kill()
        killed = datetime.now()
        assert trainer.wait(timeout=200) == 0, run.log_text("trainer")[-3000:]
        exited = datetime.now()
        # The limit counts from the trainer's start (after its imports): read when it fired from its log.
        limit_line = next(
            line for line in run.log_text("trainer").splitlines() if "wall-time limit of 1.0 minutes reached" in line
        )
        fired = datetime.strptime(limit_line[:23], "%Y-%m-%d %H:%M:%S,%f")
        assert fired > killed, "the machine is too slow for this test's time limit: it fired before Redis died"
        assert (exited - fired).total_seconds() < 15, run.log_text("trainer")[-3000:]
        assert (model / ".finished").is_file()
        assert "Training finished at checkpoint" in run.log_text("trainer")

        started = time.monotonic()
        for worker in workers:
            worker.send_signal(signal.SIGTERM)
        assert [worker.wait(30) for worker in workers] == [0, 0], run.log_text("worker-1")[-3000:]
        assert time.monotonic() - started < 30
    finally:
        run.stop_all()
