"""Every model_metadata.json + hyperparameters.json pair users have (../shared/deepracer-data/config/) either trains
an iteration or is refused before anything starts, with a message naming the file, the field and the fix.

Pairing: by file-name prefix (console2022_*, drfc1_*, dots_*, drfc_defaults_*); metadata without hyperparameters of
its own pairs with DeepRacer-for-Cloud's defaults, hyperparameters without metadata with DRfC's default metadata.
"Trains an iteration" runs the real trainer in-process against a real redis-server: preflight, set-up (checkpoint 0
with its ONNX model), one episode played in the simulator with that exported model, pushed as every episode of
iteration 0, the update (PPO or SAC), checkpoint 1, which a worker then loads and drives.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from racer.shared.config import LocalStoreSettings, ServiceSettings
from racer.shared.episode import Episode
from racer.shared.episode_loop import play_episode
from racer.shared.policy.checkpoints import CheckpointStore
from racer.shared.policy.frame_stack import frame_stacker_for
from racer.shared.redis_connection import RedisLink
from racer.shared.run_settings import RunOptions
from racer.shared.sim.env import DeepRacerEnv, EnvConfig
from racer.shared.store import open_store
from racer.shared.transport.channels import RunChannel, share_sizes
from racer.shared.user_errors import CloneError, user_error_types
from racer.trainer.preflight import UnsupportedConfigurationError, preflight
from racer.trainer.training_loop import Trainer, TrainerOptions

CONFIG = Path(__file__).resolve().parents[2].parent / "shared" / "deepracer-data" / "config"
REWARD = CONFIG.parent / "reward_functions" / "awsdoc_example_1.py"
DEFAULT_HYPERPARAMETERS = "drfc_defaults_hyperparameters.json"
DEFAULT_METADATA = "drfc_defaults_model_metadata.json"
TRANSITIONS = 16
"""The iteration trains on about this many transitions (each episode carries the played episode's first steps, at
least one): one minibatch of 16 per epoch. The update is the slow part: 80 transitions (4 steps of 20 episodes) took
the deep stereo network about two minutes on two busy cores; the update runs the same code for any count."""


def config_pairs() -> list[tuple[str, str]]:
    metadata = sorted(path.name for path in CONFIG.glob("*model_metadata*.json"))
    hyperparameters = sorted(path.name for path in CONFIG.glob("*hyperparameters*.json"))
    pairs, used = [], set()
    for name in metadata:
        prefix = name.split("model_metadata")[0]
        own = [h for h in hyperparameters if prefix and h.startswith(prefix)]
        chosen = own[0] if own else DEFAULT_HYPERPARAMETERS
        used.add(chosen)
        pairs.append((name, chosen))
    pairs += [(DEFAULT_METADATA, h) for h in hyperparameters if h not in used]
    return pairs


def test_the_pairing_covers_every_config_file():
    pairs = config_pairs()
    files = {name for pair in pairs for name in pair}
    assert files == {path.name for path in CONFIG.glob("*.json")}
    assert ("dots_model_metadata_sac.json", "dots_hyperparameters_sac.json") in pairs
    assert ("console2022_model_metadata.json", "console2022_ip_hyperparameters.json") in pairs
    assert ("drfc_defaults_model_metadata_sac.json", DEFAULT_HYPERPARAMETERS) in pairs
    assert (DEFAULT_METADATA, "drfc3_ip_hyperparameters.json") in pairs


def custom_files_from(tmp_path: Path, metadata: str, hyperparameters: str) -> Path:
    folder = tmp_path / "custom_files"
    folder.mkdir()
    shutil.copyfile(CONFIG / metadata, folder / "model_metadata.json")
    shutil.copyfile(CONFIG / hyperparameters, folder / "hyperparameters.json")
    shutil.copyfile(REWARD, folder / "reward_function.py")
    (folder / "workers.json").write_text(json.dumps({"MIN_EVAL_TRIALS": 0}))
    return folder


def first_steps(episode: Episode, steps: int, number: int) -> Episode:
    """The first `steps` of `episode`, sent as episode `number` of iteration 0 by worker `number`."""
    cut = min(steps, episode.steps)
    return Episode(
        observations={name: array[:cut] for name, array in episode.observations.items()},
        actions=episode.actions[:cut],
        rewards=episode.rewards[:cut],
        log_probs=episode.log_probs[:cut],
        policy_version=episode.policy_version,
        worker_id=number,
        world=episode.world,
        iteration=0,
        episode_number=number,
        final_status=episode.final_status,
        progress=episode.progress,
    )


@pytest.mark.slow
@pytest.mark.parametrize(("metadata", "hyperparameters"), config_pairs(), ids=lambda name: name.removesuffix(".json"))
def test_every_users_pair_trains_an_iteration_or_is_refused_before_anything_starts(
    metadata, hyperparameters, tmp_path, redis_settings
):
    custom = custom_files_from(tmp_path, metadata, hyperparameters)
    try:
        report = preflight(custom, RunOptions(1, "racer_oval", ("base",)))
    except user_error_types() as error:  # refused: the message says which file, which field, and what to do
        assert str(custom) in str(error) and "fix:" in str(error)
        return
    try:
        train_one_iteration(custom, report, tmp_path, redis_settings)
    finally:  # the deep stereo network's checkpoints take over a gigabyte each
        shutil.rmtree(tmp_path / "store", ignore_errors=True)


def train_one_iteration(custom: Path, report, tmp_path: Path, redis_settings) -> None:
    episodes = report.hyperparameters.num_episodes_between_training
    settings = ServiceSettings(redis=redis_settings, store=LocalStoreSettings(root=tmp_path / "store"))
    options = TrainerOptions(
        model_prefix="pair",
        custom_files=custom,
        run=RunOptions(num_workers=episodes, track="racer_oval", worlds=("base",)),
        sac_replay_memory_mb=64,
        sac_updates_per_transition=0.05,
    )
    trainer = Trainer(settings, options)
    assert trainer.setup() == 0

    checkpoints = CheckpointStore(open_store(settings.store), "pair")
    policy = checkpoints.load_inference_policy()  # checkpoint 0's exported model, as a worker loads it
    env = DeepRacerEnv(
        EnvConfig(
            track="racer_oval", model_metadata=report.model_metadata, reward_function_path=custom / "reward_function.py"
        )
    )
    try:
        played = play_episode(
            env,
            policy,
            greedy=False,
            generator=np.random.default_rng(0),
            policy_version=0,
            worker_id=0,
            world="base",
            episode_index=0,
        )
    finally:
        env.close()
    channel = RunChannel(RedisLink(redis_settings), "pair")
    for share, size in enumerate(share_sizes(episodes, episodes)):
        assert size == 1
        channel.push_episode(first_steps(played.episode, -(-TRANSITIONS // episodes), share))
    summary = trainer.train_iteration(0, trainer.collect(0), rollout_wall_s=1.0)
    name = trainer._save(1)

    assert summary["episodes"] == episodes
    assert checkpoints.latest_name() == name and name.startswith("1_Step-")
    trained = checkpoints.load_inference_policy(name)
    observation = {key: value[0] for key, value in played.episode.observations.items()}
    stacker = frame_stacker_for(trained)  # stack_size > 1: the first frame fills the stack, as at a reset
    action, _ = trained.act(observation if stacker is None else stacker.reset(observation), greedy=True)
    assert np.all(np.isfinite(np.asarray(action, dtype=np.float64)))
    if report.model_metadata.is_continuous:
        assert np.asarray(action).shape == (2,) and np.all(np.abs(action) <= 1.0)


# ---- refusals: what DeepRacer refuses, what racer cannot do yet ------------------------------------------------


def write_custom(tmp_path: Path, metadata: dict, hyperparameters: dict, workers: dict | None = None) -> Path:
    folder = tmp_path / "custom"
    folder.mkdir()
    (folder / "model_metadata.json").write_text(json.dumps(metadata))
    (folder / "hyperparameters.json").write_text(json.dumps(hyperparameters))
    shutil.copyfile(REWARD, folder / "reward_function.py")
    if workers is not None:
        (folder / "workers.json").write_text(json.dumps(workers))
    return folder


CONTINUOUS = {"steering_angle": {"low": -30, "high": 30}, "speed": {"low": 1, "high": 2}}
SAC_METADATA = {
    "action_space": CONTINUOUS,
    "action_space_type": "continuous",
    "training_algorithm": "sac",
    "sensor": ["FRONT_FACING_CAMERA"],
    "neural_network": "DEEP_CONVOLUTIONAL_NETWORK_SHALLOW",
    "version": "5",
}
PPO_METADATA = {**SAC_METADATA, "training_algorithm": "clipped_ppo"}


def test_ppo_with_sacs_exploration_type_is_refused_with_the_fix(tmp_path):
    custom = write_custom(tmp_path, PPO_METADATA, {"exploration_type": "additive_noise"})
    with pytest.raises(UnsupportedConfigurationError) as refused:
        preflight(custom, RunOptions(1, "racer_oval", ("base",)))
    message = str(refused.value)
    assert f"{custom / 'hyperparameters.json'}: exploration_type:" in message
    assert "fix: set exploration_type to 'categorical'" in message


def test_sac_on_a_discrete_action_space_is_refused(tmp_path):
    discrete = {
        **SAC_METADATA,
        "action_space_type": "discrete",
        "action_space": [{"steering_angle": 0, "speed": 1}, {"steering_angle": 30, "speed": 1}],
    }
    custom = write_custom(tmp_path, discrete, {})
    with pytest.raises(user_error_types(), match=r"model_metadata.json: training_algorithm: 'sac' requires"):
        preflight(custom, RunOptions(1, "racer_oval", ("base",)))


def test_sac_settings_it_ignores_are_noted_not_refused(tmp_path):
    custom = write_custom(tmp_path, SAC_METADATA, json.loads((CONFIG / DEFAULT_HYPERPARAMETERS).read_text()))
    report = preflight(custom, RunOptions(2, "racer_oval", ("base",)))
    assert report.model_metadata.training_algorithm == "sac"
    assert any(
        "beta_entropy, e_greedy_value, epsilon_steps, exploration_type, num_epochs: not used by SAC" in w
        for w in report.warnings
    )


@pytest.mark.parametrize(
    ("workers", "field"),
    [
        ({"RACE_TYPE": "OBJECT_AVOIDANCE"}, "NUMBER_OF_OBSTACLES"),
        ({"workers": [{}, {"RACE_TYPE": "HEAD_TO_BOT"}]}, "NUMBER_OF_BOT_CARS"),
        ({"NUMBER_OF_OBSTACLES": 6}, "RACE_TYPE"),
        ({"RACE_TYPE": "HEAD_TO_MODEL"}, "RACE_TYPE"),
        ({"RACE_TYPE": "OBJECT_AVOIDANCE", "NUMBER_OF_OBSTACLES": 3, "OBSTACLE_TYPE": "cone"}, "OBSTACLE_TYPE"),
    ],
)
def test_race_settings_that_cannot_run_are_refused_naming_the_key(tmp_path, workers, field):
    custom = write_custom(tmp_path, PPO_METADATA, {}, workers)
    with pytest.raises(user_error_types()) as refused:
        preflight(custom, RunOptions(2, "racer_oval", ("base",)))
    assert str(custom / "workers.json") in str(refused.value) and f"{field}:" in str(refused.value)


def test_object_avoidance_and_head_to_bot_pass_the_preflight(tmp_path):
    custom = write_custom(
        tmp_path,
        PPO_METADATA,
        {},
        {
            "RACE_TYPE": "OBJECT_AVOIDANCE",
            "NUMBER_OF_OBSTACLES": 6,
            "workers": [{}, {"RACE_TYPE": "HEAD_TO_BOT", "NUMBER_OF_OBSTACLES": 0, "NUMBER_OF_BOT_CARS": 3}],
        },
    )
    report = preflight(custom, RunOptions(2, "racer_oval", ("base",)))
    assert [
        (w.challenge.race_type, w.challenge.num_obstacles, w.challenge.number_of_bot_cars) for w in report.workers
    ] == [
        ("OBJECT_AVOIDANCE", 6, 0),
        ("HEAD_TO_BOT", 0, 3),
    ]


def test_a_missing_file_and_a_missing_track_are_named(tmp_path):
    custom = write_custom(tmp_path, PPO_METADATA, {})
    with pytest.raises(user_error_types(), match="no track named 'nowhere'"):
        preflight(custom, RunOptions(1, "nowhere", ("base",)))
    (custom / "hyperparameters.json").unlink()
    with pytest.raises(user_error_types(), match="missing hyperparameters.json"):
        preflight(custom, RunOptions(1, "racer_oval", ("base",)))


def test_cloning_sac_from_ppo_is_refused_before_anything_starts(tmp_path):
    store_root = tmp_path / "racer-data"
    store = open_store(LocalStoreSettings(root=store_root))
    store.put_bytes("ppo-model/model/model_metadata.json", json.dumps(PPO_METADATA).encode())
    custom = write_custom(tmp_path, SAC_METADATA, {})
    with pytest.raises(
        CloneError,
        match=r"training_algorithm: cannot clone 'ppo-model': it was trained with "
        r"clipped_ppo, this model asks for sac.*fix: clone a sac model",
    ):
        preflight(custom, RunOptions(1, "racer_oval", ("base",)), pretrained_prefix="ppo-model", store=store)


def test_racer_train_refuses_before_starting_redis_or_any_process(tmp_path, monkeypatch):
    from racer.local.cli import train_command

    custom = write_custom(tmp_path, PPO_METADATA, {"exploration_type": "additive_noise"})
    monkeypatch.setenv("RACER_STORE", str(tmp_path / "racer-data"))
    result = CliRunner().invoke(train_command, ["--custom-files", str(custom), "--model-prefix", "refused"])
    assert result.exit_code == 1
    assert "exploration_type" in result.output and "fix:" in result.output
    assert "Traceback" not in result.output
    assert not (tmp_path / "racer-data" / ".runs").exists()  # no log folder: no redis-server, no trainer, no worker


def test_racer_trainer_refuses_before_connecting(tmp_path, monkeypatch):
    from racer.trainer.cli import trainer_command

    custom = write_custom(tmp_path, PPO_METADATA, {}, {"RACE_TYPE": "OBJECT_AVOIDANCE"})
    monkeypatch.setenv("RACER_REDIS_URL", "redis://127.0.0.1:1/0")  # nothing listens there: a connection would fail
    monkeypatch.setenv("RACER_STORE", str(tmp_path / "racer-data"))
    result = CliRunner().invoke(trainer_command, ["--model-prefix", "m", "--custom-files", str(custom)])
    assert result.exit_code == 1
    assert "NUMBER_OF_OBSTACLES" in result.output and "OBJECT_AVOIDANCE needs obstacles" in result.output
    assert not (tmp_path / "racer-data").exists()
