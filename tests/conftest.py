"""Fixtures shared by the whole suite: real redis-server and MinIO processes, and the shared data folder."""

from __future__ import annotations

import json
import os
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from racer.local.services import MinioServer, RedisServer
from racer.shared.config import RedisSettings, S3Settings
from racer.shared.store import S3Store
from tests.shared_data import SHARED_DATA

os.environ.setdefault("MUJOCO_GL", "egl")


def _missing_data_message(count: int) -> str:
    return (
        f"{count} selected tests read real DeepRacer files from {SHARED_DATA}, which is missing. The folder "
        f"comes with the project's shared/ folder, checked out beside this repository (../shared/deepracer-data; "
        f"README, 'Test data'). Run from such a checkout, or deselect those tests."
    )


def pytest_collection_modifyitems(config, items):
    """One clear error before anything runs, instead of a FileNotFoundError in every test that needs the data."""
    needing = [item for item in items if "deepracer_data" in getattr(item, "fixturenames", ())]
    if needing and not SHARED_DATA.is_dir():
        raise pytest.UsageError(_missing_data_message(len(needing)))


@pytest.fixture(scope="session", autouse=True)
def simapp_tracks_offline(tmp_path_factory) -> Iterator[None]:
    """Tracks named by their SimApp name come from the shared route files into a cache of the session's own, never
    from the network (child processes inherit both settings)."""
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("RACER_TRACKS_URL", str(SHARED_DATA / "simapp-routes"))
        patch.setenv("RACER_CACHE_HOME", str(tmp_path_factory.mktemp("racer-cache")))
        yield


@pytest.fixture(scope="session")
def two_short_runs(tmp_path_factory) -> tuple[Path, Path]:
    """Two short real runs in one store (tests.short_runs.train_two_short_runs), trained once per pytest run for the
    compare page and the viewer's run list: pytest-xdist workers share them (the first to ask trains them under a
    file lock while the other waits), so those tests may run on either worker."""
    from tests.short_runs import shared_short_runs

    base = tmp_path_factory.getbasetemp()
    # A worker's basetemp is popen-gw<N> in the run's own folder, which the controller removes after a passing run.
    return shared_short_runs(base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base)


@pytest.fixture(scope="session")
def deepracer_data() -> Path:
    """The real DeepRacer files; tests (and test modules, with `usefixtures`) that read them ask for this."""
    if not SHARED_DATA.is_dir():
        raise FileNotFoundError(_missing_data_message(1))
    return SHARED_DATA


@pytest.fixture
def redis_server(tmp_path_factory):
    """A fresh redis-server (project redis.conf, loopback, own port and data dir), stopped afterwards.

    Tests may call .restart(), .kill() or .start() on it.
    """
    server = RedisServer(tmp_path_factory.mktemp("redis"))
    server.start()
    yield server
    server.stop()


@pytest.fixture
def redis_settings(redis_server) -> RedisSettings:
    return RedisSettings(url=redis_server.url, connect_timeout_s=5.0)


@pytest.fixture(scope="session")
def minio_server(tmp_path_factory):
    """One MinIO server for the session (it takes a second or two to start); tests use their own buckets."""
    server = MinioServer(tmp_path_factory.mktemp("minio"))
    server.start(timeout_s=60)
    yield server
    server.stop()


@pytest.fixture
def s3_settings(minio_server, request) -> Iterator[S3Settings]:
    """Settings for a new, empty bucket in the session's MinIO."""
    bucket = "t-" + "".join(c for c in request.node.name.lower() if c.isalnum())[:40] + f"-{os.getpid() % 10000}"
    settings = S3Settings(
        bucket=bucket,
        endpoint_url=minio_server.endpoint_url,
        access_key_id=minio_server.access_key,
        secret_access_key=minio_server.secret_key,
        connect_timeout_s=5.0,
    )
    store = S3Store(settings)
    store.ensure_bucket()
    yield settings
    # The session's MinIO would otherwise keep every test's checkpoints (gigabytes by the end of the suite).
    if minio_server.running:
        for key in store.list_keys(""):
            store.delete(key)


def make_episode(
    steps: int,
    seed: int,
    continuous: bool = False,
    worker_id: int = 1,
    world: str = "carpet",
    policy_version: int = 3,
    iteration: int = 3,
    episode_number: int = 0,
):
    """A synthetic episode with camera frames and lidar, for transport and trainer-plumbing tests."""
    from racer.shared.episode import Episode

    rng = np.random.default_rng(seed)
    frames = rng.integers(0, 255, size=(steps, 120, 160, 1), dtype=np.uint8)
    frames[:, :60] = 90  # a flat sky-like area, as rendered frames have
    actions = rng.uniform(-1, 1, (steps, 2)).astype(np.float32) if continuous else rng.integers(0, 5, steps)
    return Episode(
        observations={"FRONT_FACING_CAMERA": frames, "LIDAR": rng.uniform(0.15, 1, (steps, 64)).astype(np.float32)},
        actions=actions,
        rewards=rng.uniform(0, 1, steps).astype(np.float32),
        log_probs=rng.uniform(-2, 0, steps).astype(np.float32),
        policy_version=policy_version,
        worker_id=worker_id,
        world=world,
        iteration=iteration,
        episode_number=episode_number,
        episode_index=seed,
        final_status="off_track",
        progress=12.5,
        info={"lap_time_s": 0.0},
    )


@pytest.fixture
def episode_factory():
    return make_episode


CONSTANT_REWARD = "def reward_function(params):\n    return 1.0\n"


def write_custom_files(
    folder: Path,
    *,
    steering_deg: tuple[float, ...] = (-30, 0, 30),
    reward_source: str = CONSTANT_REWARD,
    min_eval_trials: int | None = 1,
    eval_max_steps: int = 300,
) -> Path:
    """A small custom_files folder, as users bring it, for tests that train: shallow camera network, one speed,
    2 episodes per iteration; `min_eval_trials` None writes no workers.json. `eval_max_steps` (RACER_EVAL_MAX_STEPS)
    caps worker 0's evaluation episodes at about 1.5 laps of the oval: a barely trained greedy policy may circle
    without leaving the track, and the run would wait for it (up to DeepRacer's 100,000 steps)."""
    folder.mkdir(parents=True)
    (folder / "reward_function.py").write_text(reward_source)
    actions = [{"steering_angle": angle, "speed": 1.0} for angle in steering_deg]
    (folder / "model_metadata.json").write_text(
        json.dumps(
            {
                "action_space": actions,
                "sensor": ["FRONT_FACING_CAMERA"],
                "version": "5",
                "neural_network": "DEEP_CONVOLUTIONAL_NETWORK_SHALLOW",
                "training_algorithm": "clipped_ppo",
            }
        )
    )
    (folder / "hyperparameters.json").write_text(
        json.dumps({"num_episodes_between_training": 2, "batch_size": 32, "num_epochs": 3})
    )
    if min_eval_trials is not None:
        workers = {"MIN_EVAL_TRIALS": min_eval_trials, "RACER_EVAL_MAX_STEPS": eval_max_steps}
        (folder / "workers.json").write_text(json.dumps(workers))
    return folder
