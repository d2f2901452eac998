"""DeepRacer's MAX_MEMORY_STEPS (SimApp deepracer_memory.py): an iteration trains on the episodes, in their global
order, while the running step count stays within the cap; the first one past it and all later ones are dropped."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from racer.shared.config import LocalStoreSettings, ServiceSettings, max_memory_steps_from_env
from racer.shared.policy.checkpoints import CheckpointStore
from racer.shared.redis_connection import RedisLink
from racer.shared.run_settings import RunOptions
from racer.shared.store import open_store
from racer.shared.transport.channels import RunChannel
from racer.trainer.memory_cap import cap_episodes, default_max_memory_steps, global_episode_order
from racer.trainer.training_loop import Trainer, TrainerOptions
from tests.conftest import make_episode, write_custom_files

PREFIX = "cap-model"


def _episodes(lengths, worker_id=0):
    return [make_episode(steps, seed=i, worker_id=worker_id) for i, steps in enumerate(lengths)]


def test_deepracers_caps_per_network_and_the_environment_override(deepracer_data):
    assert default_max_memory_steps("DEEP_CONVOLUTIONAL_NETWORK_SHALLOW") == 10_000
    assert default_max_memory_steps("DEEP_CONVOLUTIONAL_NETWORK") == 3_000
    assert default_max_memory_steps("DEEP_CONVOLUTIONAL_NETWORK_DEEP") == 3_000
    assert max_memory_steps_from_env({}) is None
    assert max_memory_steps_from_env({"MAX_MEMORY_STEPS": "25000"}) == 25_000
    with pytest.raises(ValueError, match="MAX_MEMORY_STEPS"):
        max_memory_steps_from_env({"MAX_MEMORY_STEPS": "lots"})


def test_episodes_are_kept_in_global_order_while_the_running_count_is_within_the_cap():
    share0, share1 = _episodes([100, 200, 300], worker_id=0), _episodes([50, 60, 70], worker_id=1)
    by_number = {1 + 2 * j: episode for j, episode in enumerate(share1)} | {2 * j: e for j, e in enumerate(share0)}
    ordered = global_episode_order(by_number)
    assert ordered == [share0[0], share1[0], share0[1], share1[1], share0[2], share1[2]]  # episodes 0, 1, 2, ...
    capped = cap_episodes(ordered, max_steps=410)  # 100 + 50 + 200 + 60 = 410 fits; + 300 does not
    assert capped.kept == (share0[0], share1[0], share0[1], share1[1])
    assert capped.dropped == (share0[2], share1[2])  # the short one after the first overflow is dropped too
    assert (capped.kept_steps, capped.dropped_steps) == (410, 370)
    assert cap_episodes(ordered, max_steps=0).kept == tuple(ordered)
    assert cap_episodes(ordered, max_steps=None).dropped == ()
    assert cap_episodes(ordered, max_steps=50).kept == (share0[0],)  # never an empty iteration


def test_the_trainer_drops_episodes_beyond_the_cap_and_counts_only_trained_steps(redis_settings, tmp_path: Path):
    custom_files = write_custom_files(
        tmp_path / "custom_files", steering_deg=(-30, -15, 0, 15, 30), min_eval_trials=None
    )
    hyper = json.loads((custom_files / "hyperparameters.json").read_text())
    (custom_files / "hyperparameters.json").write_text(json.dumps({**hyper, "num_episodes_between_training": 4}))
    settings = ServiceSettings(redis=redis_settings, store=LocalStoreSettings(root=tmp_path / "store"))
    trainer = Trainer(
        settings,
        TrainerOptions(
            model_prefix=PREFIX,
            custom_files=custom_files,
            run=RunOptions(num_workers=2, track="racer_oval", worlds=("base",)),
            max_memory_steps=70,
        ),
    )
    assert trainer.setup() == 0
    channel = RunChannel(RedisLink(redis_settings), PREFIX)
    # One stream entry per claimed episode, which carries its number in the iteration.
    for episode_number, length in enumerate([30, 30, 30, 20]):
        worker_id = episode_number % 2
        channel.push_episode(
            make_episode(
                length,
                seed=episode_number,
                worker_id=worker_id,
                world="base",
                policy_version=0,
                iteration=0,
                episode_number=episode_number,
            )
        )
    summary = trainer.train_iteration(0, trainer.collect(0), rollout_wall_s=1.0)
    # Episodes in number order 30, 30, 30, 20: 60 fits, 90 does not -> two trained, two dropped.
    assert (summary["episodes"], summary["episodes_dropped"], summary["steps_dropped"]) == (2, 2, 50)
    assert summary["env_steps_total"] == 60
    name = trainer._save(1)
    assert name == "1_Step-60.ckpt"
    assert CheckpointStore(open_store(settings.store), PREFIX).latest_name() == name
