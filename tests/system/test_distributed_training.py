"""Distributed training end to end: real redis-server, real MinIO, trainer and rollout workers as processes.

Small on purpose (2 episodes per iteration on the shortest shipped track) so each scenario runs in about a minute.
"""

from __future__ import annotations

import json
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from racer.local.run import service_environment
from racer.local.services import _die_with_parent
from racer.shared.config import RedisSettings, ServiceSettings
from racer.shared.deepracer.hyperparameters import load_hyperparameters
from racer.shared.deepracer.simtrace import read_simtrace
from racer.shared.model_layout import ModelLayout
from racer.shared.redis_connection import RedisLink
from racer.shared.store import open_store
from racer.shared.transport.channels import RunChannel
from tests.conftest import write_custom_files

pytestmark = [pytest.mark.slow, pytest.mark.heavy]  # trainers and workers as processes

TRACK = "racer_oval"
CHECKPOINT_NAME = re.compile(r"^(\d+)_Step-(\d+)\.ckpt$")


@pytest.fixture
def custom_files(tmp_path: Path) -> Path:
    centre_line = (
        "def reward_function(params):\n"
        "    return 1.0 - min(1.0, params['distance_from_center'] / (0.5 * params['track_width']))\n"
    )
    return write_custom_files(tmp_path / "custom_files", reward_source=centre_line)


class SystemRun:
    """Starts and watches the processes of one training run."""

    def __init__(self, settings: ServiceSettings, prefix: str, custom_files: Path, logs: Path, workers: int = 2):
        self.settings = settings
        self.prefix = prefix
        self.custom_files = custom_files
        self.logs = logs
        self.workers = workers
        self.processes: dict[str, subprocess.Popen] = {}
        logs.mkdir(parents=True, exist_ok=True)
        self.temp = logs / "tmp"  # the processes' TMPDIR, so a test can see what they leave behind
        self.temp.mkdir(exist_ok=True)

    def start(self, name: str, *args: str) -> subprocess.Popen:
        log = open(self.logs / f"{name}.log", "ab")
        process = subprocess.Popen(
            [sys.executable, "-m", "racer.cli", *args],
            stdout=log,
            stderr=subprocess.STDOUT,
            env={**service_environment(self.settings), "TMPDIR": str(self.temp)},
            preexec_fn=_die_with_parent,
        )
        self.processes[name] = process
        return process

    def start_trainer(self, max_episodes: int, *extra: str) -> subprocess.Popen:
        return self.start(
            "trainer",
            "trainer",
            "--model-prefix",
            self.prefix,
            "--custom-files",
            str(self.custom_files),
            "--workers",
            str(self.workers),
            "--track",
            TRACK,
            "--worlds",
            "base,carpet",
            "--max-episodes",
            str(max_episodes),
            *extra,
        )

    def start_worker(self, worker_id: int) -> subprocess.Popen:
        return self.start(
            f"worker-{worker_id}",
            "rollout",
            "--model-prefix",
            self.prefix,
            "--worker-id",
            str(worker_id),
            "--seed",
            str(worker_id),
            "--wait-timeout-s",
            "300",
        )

    def log_text(self, name: str) -> str:
        path = self.logs / f"{name}.log"
        return path.read_text(errors="replace") if path.exists() else ""

    def wait_trainer(self, timeout_s: float) -> int:
        try:
            return self.processes["trainer"].wait(timeout_s)
        except subprocess.TimeoutExpired:
            raise AssertionError(
                "trainer did not finish in time; log tail:\n"
                + self.log_text("trainer")[-4000:]
                + "\nworker-0 tail:\n"
                + self.log_text("worker-0")[-3000:]
            ) from None

    def stop_all(self) -> None:
        for process in self.processes.values():
            if process.poll() is None:
                process.send_signal(signal.SIGTERM)
        for process in self.processes.values():
            try:
                process.wait(20)
            except subprocess.TimeoutExpired:
                process.kill()


@pytest.fixture
def system(redis_server, s3_settings, custom_files, tmp_path, request):
    settings = ServiceSettings(redis=RedisSettings(url=redis_server.url, connect_timeout_s=10), store=s3_settings)
    run = SystemRun(settings, "model-e2e", custom_files, tmp_path / "logs")
    yield run
    run.stop_all()


def checkpoint_numbers(store, prefix: str) -> list[int]:
    names = {Path(key).name.split(".ckpt")[0] for key in store.list_keys(f"{prefix}/model/") if ".ckpt" in key}
    return sorted(int(name.split("_")[0]) for name in names)


def iteration_records(store, prefix: str) -> list[dict]:
    text = store.get_bytes(ModelLayout(prefix).iterations_log).decode()
    return [json.loads(line) for line in text.splitlines() if line.strip()]


def test_two_workers_two_worlds_two_iterations(system):
    store = open_store(system.settings.store)
    (system.custom_files / "preset.json").write_text(json.dumps({"anneal_lr": True}))
    system.start_trainer(max_episodes=4)
    system.start_worker(0)
    system.start_worker(1)
    assert system.wait_trainer(600) == 0, system.log_text("trainer")[-3000:]

    prefix = system.prefix
    assert checkpoint_numbers(store, prefix) == [0, 1, 2]
    pointer = store.get_bytes(f"{prefix}/model/.coach_checkpoint").decode().strip()
    match = CHECKPOINT_NAME.match(pointer)
    assert match and match.group(1) == "2", pointer
    records = iteration_records(store, prefix)
    assert [r["episodes"] for r in records] == [2, 2]
    lr = load_hyperparameters(system.custom_files / "hyperparameters.json")[0].lr
    # anneal_lr: the first update with 0 of the 4 episodes used, the second with 2
    assert [r["learning_rate"] for r in records] == pytest.approx([lr, lr / 2])
    assert int(match.group(2)) == records[-1]["env_steps_total"]  # M in N_Step-M = env steps consumed
    for worker_id in (0, 1):
        for iteration in (0, 1):
            assert store.exists(f"{prefix}/{worker_id}/training-simtrace/{iteration}-iteration.csv")
    assert store.exists(f"{prefix}/metrics/TrainingMetrics.json")
    assert store.exists(f"{prefix}/metrics/TrainingMetrics_1.json")
    assert store.exists(f"{prefix}/model/.finished")
    assert store.exists(f"{prefix}/ip/hyperparameters.json")
    assert store.exists(f"{prefix}/reward_function.py")
    assert store.exists(f"{prefix}/training_params.yaml")
    assert store.exists(f"{prefix}/training_params_1.yaml")  # worker 1 differs (carpet)
    best_last = json.loads(store.get_bytes(f"{prefix}/model/deepracer_checkpoints.json"))
    assert set(best_last) == {"best_checkpoint", "last_checkpoint"}
    assert CHECKPOINT_NAME.match(best_last["last_checkpoint"]["name"])
    trainer_log = system.log_text("trainer")
    for worker_id in (0, 1):
        assert re.search(
            rf"Training> Name=main_level/agent, Worker={worker_id}, Episode=\d+, Total reward=[-\d.e]+, "
            r"Steps=\d+, Training iteration=\d+",
            trainer_log,
        )
    assert len(re.findall(r"Policy training> Surrogate loss=", trainer_log)) == 2 * 3  # 2 iterations x 3 epochs
    metrics = json.loads(store.get_bytes(f"{prefix}/metrics/TrainingMetrics_1.json"))
    assert {e["phase"] for e in metrics["metrics"]} == {"training"}  # only worker 0 evaluates
    for process in system.processes.values():
        assert process.wait(30) == 0
    assert sorted(system.temp.glob("racer-*")) == []  # the workers' download folders are gone with them


MODES = {"strict": (), "overlap": ("--overlap",)}
"""DeepRacer's alternation, and workers that play iteration k+1 while k trains: the chaos tests run under both."""


@pytest.mark.parametrize("mode", MODES)
def test_worker_killed_mid_iteration(system, mode):
    """kill -9 one worker while it plays: the other replays its share; every iteration uses exactly E episodes."""
    store = open_store(system.settings.store)
    hyperparameters = json.loads((system.custom_files / "hyperparameters.json").read_text())
    (system.custom_files / "hyperparameters.json").write_text(
        json.dumps({**hyperparameters, "num_episodes_between_training": 6})
    )
    system.start_trainer(18, *MODES[mode])
    system.start_worker(0)
    victim = system.start_worker(1)
    channel = RunChannel(RedisLink(system.settings.redis), system.prefix)
    deadline = time.monotonic() + 300
    while time.monotonic() < deadline:
        beat = channel.live_workers().get(1, {})
        if beat.get("state") == "playing" and beat.get("iteration", -1) >= 1:
            break
        time.sleep(0.05)
    else:
        raise AssertionError("worker 1 never started playing iteration 1:\n" + system.log_text("worker-1")[-3000:])
    victim.send_signal(signal.SIGKILL)
    assert system.wait_trainer(600) == 0, system.log_text("trainer")[-3000:]
    records = iteration_records(store, system.prefix)
    assert [r["episodes"] for r in records] == [6, 6, 6]
    assert all(r["kl_divergence"] is not None and r["learning_rate"] > 0 for r in records)  # in both modes
    if mode == "overlap":  # iterations 1 and 2 were queued before the update: played by the checkpoint before
        assert [r["episodes_one_behind_share"] > 0 for r in records] == [False, True, True]
        assert "taking up checkpoint" in system.log_text("worker-0")  # a new checkpoint between episodes
        judged = re.findall(r"evaluation of (\d+)_Step", system.log_text("worker-0"))
        assert judged == ["0", "1", "2"]  # each checkpoint once, under its own number, as a strict run judges them
    else:
        assert all("episodes_one_behind_share" not in r for r in records)
    assert "replays it" in system.log_text("trainer")
    assert checkpoint_numbers(store, system.prefix)[-1] == 3
    # The simtrace `episode` is worker 0's running count of training episodes (the SimApp's counter, as in the real
    # files: console2022_training_1 starts at 20), so after the replay it goes on from there, as TrainingMetrics does.
    metrics = json.loads(store.get_bytes(f"{system.prefix}/metrics/TrainingMetrics.json"))["metrics"]
    training = [entry["episode"] for entry in metrics if entry["phase"] == "training"]
    assert training == list(range(1, len(training) + 1)) and len(training) > 9
    last = read_simtrace(store.get_bytes(f"{system.prefix}/0/training-simtrace/2-iteration.csv"), source="2-iteration")
    episodes = sorted(last.episode.unique())
    assert episodes == [episode - 1 for episode in training[-len(episodes) :]]


@pytest.mark.parametrize("mode", MODES)
def test_redis_restart_mid_run_then_the_trainer_killed_and_restarted_resumes(system, redis_server, mode):
    """One run, two faults: Redis restarts after checkpoint 1 and the trainer and workers train on through it to
    checkpoint 2; then the trainer is killed (-9), and a new one resumes from the last checkpoint and finishes."""
    store = open_store(system.settings.store)
    trainer = system.start_trainer(6, *MODES[mode])
    system.start_worker(0)
    system.start_worker(1)

    def wait_for_checkpoint(number: int) -> None:
        deadline = time.monotonic() + 300
        while time.monotonic() < deadline and checkpoint_numbers(store, system.prefix)[-1:] != [number]:
            assert trainer.poll() is None, system.log_text("trainer")[-3000:]
            time.sleep(0.3)
        assert checkpoint_numbers(store, system.prefix)[-1:] == [number], system.log_text("trainer")[-3000:]

    wait_for_checkpoint(1)
    redis_server.restart()
    wait_for_checkpoint(2)  # trained on through the restart
    trainer.send_signal(signal.SIGKILL)
    trainer.wait()
    before = checkpoint_numbers(store, system.prefix)
    system.start_trainer(6, *MODES[mode])
    assert system.wait_trainer(600) == 0, system.log_text("trainer")[-3000:]
    assert "resuming model-e2e from checkpoint" in system.log_text("trainer")
    after = checkpoint_numbers(store, system.prefix)
    assert after[-1] == 3 and after[-1] > before[-1]
    assert [r["iteration"] for r in iteration_records(store, system.prefix)] == [0, 1, 2][
        -len(iteration_records(store, system.prefix)) :
    ]


def test_sigterm_stops_the_trainer_cleanly_and_the_workers_follow(system):
    """What `docker stop` / `docker compose stop` does: the trainer finishes, marks the model finished, exits 0,
    and the workers, told by the trainer, exit 0 too."""
    store = open_store(system.settings.store)
    trainer = system.start_trainer(max_episodes=1000)
    workers = [system.start_worker(0), system.start_worker(1)]
    deadline = time.monotonic() + 300
    while time.monotonic() < deadline and checkpoint_numbers(store, system.prefix)[-1:] != [1]:
        time.sleep(0.3)
    assert checkpoint_numbers(store, system.prefix)[-1] >= 1
    trainer.send_signal(signal.SIGTERM)
    assert trainer.wait(120) == 0, system.log_text("trainer")[-3000:]
    assert store.exists(ModelLayout(system.prefix).finished)
    assert "Training finished at checkpoint" in system.log_text("trainer")
    for worker in workers:
        assert worker.wait(60) == 0


def test_clone_with_different_action_count_is_a_clear_error(system, custom_files, tmp_path):
    """The trainer process refuses before it starts. The clone check reads the source's model/model_metadata.json
    alone (racer.trainer.preflight.check_clone_source), so the source is that file, as a finished run leaves it
    (a trainer that clones a stored model: tests/model_io/test_model_sac.py::test_sac_clones_sac)."""
    store = open_store(system.settings.store)
    store.put_bytes(f"{system.prefix}/model/model_metadata.json", (custom_files / "model_metadata.json").read_bytes())
    clone_files = tmp_path / "clone_files"
    clone_files.mkdir()
    for name in ("reward_function.py", "hyperparameters.json"):
        (clone_files / name).write_bytes((custom_files / name).read_bytes())
    metadata = json.loads((custom_files / "model_metadata.json").read_text())
    metadata["action_space"] = metadata["action_space"][:2]
    (clone_files / "model_metadata.json").write_text(json.dumps(metadata))
    clone = SystemRun(system.settings, "model-clone", clone_files, tmp_path / "clone-logs")
    process = clone.start_trainer(2, "--pretrained-prefix", system.prefix)
    assert process.wait(120) != 0
    log = clone.log_text("trainer")
    assert "model-e2e" in log and "3 actions" in log and "2 actions" in log, log[-2000:]
    assert not store.exists("model-clone/model/.coach_checkpoint")
