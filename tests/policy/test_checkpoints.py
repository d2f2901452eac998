"""Checkpoints through LocalStore and a real MinIO: round trips, ONNX, retention, atomic publishing."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import onnx
import onnxruntime
import pytest
import torch

from racer.shared.deepracer.hyperparameters import Hyperparameters
from racer.shared.deepracer.model_metadata import parse_model_metadata
from racer.shared.model_layout import CheckpointName
from racer.shared.policy.best_and_last import CheckpointRecord
from racer.shared.policy.checkpoints import CheckpointStore
from racer.shared.policy.manifest import CheckpointError
from racer.shared.policy.networks import ActorCritic, build_actor_critic
from racer.shared.policy.onnx_export import export_onnx
from racer.shared.policy.optimizer_files import load_optimizer_state
from racer.shared.store import LocalStore, S3Store
from racer.trainer.ppo import PPOLearner, PPOSettings
from tests.trainer.ppo_task import random_episodes

PREFIX = "runs/model-a"
HP = Hyperparameters(batch_size=32, num_epochs=1, lr=3e-4, discount_factor=0.99, loss_type="huber")
ACTIONS = [{"steering_angle": angle, "speed": 1.0} for angle in (-30, 0, 30)]


def small_metadata(continuous: bool = False, sensors=("FRONT_FACING_CAMERA", "LIDAR")):
    """DEEP_CONVOLUTIONAL_NETWORK_DEEP: the smallest of the three (1152-wide flatten), keeps store tests quick."""
    data = {
        "action_space": ACTIONS,
        "sensor": list(sensors),
        "neural_network": "DEEP_CONVOLUTIONAL_NETWORK_DEEP",
        "version": "5",
    }
    if continuous:
        data.update(
            action_space={"steering_angle": {"low": -30, "high": 30}, "speed": {"low": 0.5, "high": 2.0}},
            action_space_type="continuous",
        )
    return parse_model_metadata(data)


def observation_batch(network: ActorCritic, seed: int, size: int = 4) -> dict[str, torch.Tensor]:
    rng = np.random.default_rng(seed)
    batch = {}
    for spec in network.config.inputs:
        if spec.kind == "camera":
            batch[spec.name] = torch.from_numpy(rng.integers(0, 256, size=(size, *spec.shape), dtype=np.uint8))
        else:
            batch[spec.name] = torch.from_numpy(rng.uniform(0.15, 1, size=(size, *spec.shape)).astype(np.float32))
    return batch


def outputs(network: ActorCritic, batch) -> tuple[torch.Tensor, torch.Tensor]:
    with torch.no_grad():
        return network.policy_output(batch), network.value(batch)


def trained(seed: int = 0, continuous: bool = False) -> tuple[PPOLearner, list]:
    torch.manual_seed(seed)
    network = build_actor_critic(small_metadata(continuous))
    learner = PPOLearner(network, HP, PPOSettings(seed=seed))
    episodes = random_episodes(network, [40, 30], np.random.default_rng(seed))
    learner.update(episodes)
    return learner, episodes


def continue_training(network: ActorCritic, optimizer_state, episodes) -> dict[str, torch.Tensor]:
    learner = PPOLearner(network, HP, PPOSettings(seed=99))
    load_optimizer_state(learner.optimizer, network, optimizer_state)
    learner.update(episodes)
    return {name: value.clone() for name, value in network.state_dict().items()}


@pytest.fixture(params=["local", "minio"])
def store(request, tmp_path):
    if request.param == "local":
        return LocalStore(tmp_path / "store")
    return S3Store(request.getfixturevalue("s3_settings"))


def test_round_trip_gives_identical_outputs_and_training_continues_identically(store):
    learner, episodes = trained()
    checkpoints = CheckpointStore(store, PREFIX)
    md = small_metadata()
    name = checkpoints.save(0, 70, learner.network, learner.optimizer, model_metadata=md, hyperparameters=HP)
    assert name == "0_Step-70.ckpt"
    assert checkpoints.latest_name() == name and checkpoints.names() == [name]
    assert store.get_bytes(f"{PREFIX}/model/.coach_checkpoint") == b"0_Step-70.ckpt\n"
    assert not store.exists(f"{PREFIX}/model/.lock")

    batch = observation_batch(learner.network, seed=1)
    policy = checkpoints.load_policy()
    assert not policy.training
    for original, restored in zip(outputs(learner.network, batch), outputs(policy, batch), strict=True):
        assert torch.equal(original, restored)

    loaded = checkpoints.load(name)
    assert loaded.info.env_steps == 70 and loaded.info.policy_config == learner.network.config
    assert loaded.info.model_metadata["neural_network"] == "DEEP_CONVOLUTIONAL_NETWORK_DEEP"
    assert loaded.info.hyperparameters["batch_size"] == 32 and loaded.info.versions["torch"] == torch.__version__

    # Resuming = continuing without a restart, bit for bit (optimiser moments, step counts and lr restored).
    resumed_network = ActorCritic(loaded.info.policy_config)
    resumed_network.load_state_dict(loaded.network_state)
    resumed = continue_training(resumed_network, loaded.optimizer_state, episodes)
    uninterrupted = continue_training(learner.network, learner.optimizer.state_dict(), episodes)
    assert all(torch.equal(resumed[key], uninterrupted[key]) for key in uninterrupted)


def test_local_store_and_minio_give_identical_outputs(tmp_path, s3_settings):
    learner, _ = trained(seed=3)
    batch = observation_batch(learner.network, seed=2)
    results = []
    for store in (LocalStore(tmp_path / "local"), S3Store(s3_settings)):
        checkpoints = CheckpointStore(store, PREFIX)
        checkpoints.save(0, 5, learner.network, learner.optimizer)
        results.append(outputs(checkpoints.load_policy(), batch))
        results.append(checkpoints.load().optimizer_state)
    (local_out, local_opt, s3_out, s3_opt) = results
    assert all(torch.equal(a, b) for a, b in zip(local_out, s3_out, strict=True))
    assert local_opt["param_groups"] == s3_opt["param_groups"]
    for index, state in local_opt["state"].items():
        assert all(torch.equal(state[key], s3_opt["state"][index][key]) for key in state)


@pytest.mark.parametrize("continuous", [False, True])
def test_onnx_model_matches_the_network(tmp_path, continuous):
    torch.manual_seed(4)
    network = build_actor_critic(small_metadata(continuous))
    checkpoints = CheckpointStore(LocalStore(tmp_path), PREFIX)
    checkpoints.save(0, 0, network)
    data = LocalStore(tmp_path).get_bytes(f"{PREFIX}/model/model_0.onnx")
    model = onnx.load_from_string(data)
    onnx.checker.check_model(model)
    shapes = {i.name: [d.dim_value for d in i.type.tensor_type.shape.dim] for i in model.graph.input}
    assert shapes == {"FRONT_FACING_CAMERA": [1, 120, 160, 1], "LIDAR": [1, 64]}
    assert [o.name for o in model.graph.output] == ["policy"]
    session = onnxruntime.InferenceSession(data, providers=["CPUExecutionProvider"])
    batch = observation_batch(network, seed=5, size=1)
    feed = {name: tensor.float().numpy() for name, tensor in batch.items()}  # raw 0-255 grayscale as float
    (onnx_output,) = session.run(None, feed)
    expected, _ = outputs(network, batch)
    assert onnx_output.shape == ((1, 2) if continuous else (1, 3))
    np.testing.assert_allclose(onnx_output, expected.numpy(), rtol=1e-4, atol=1e-6)
    if not continuous:
        assert onnx_output.sum() == pytest.approx(1.0, abs=1e-5)


def test_export_onnx_stereo_camera_shape():
    torch.manual_seed(0)
    network = build_actor_critic(small_metadata(sensors=("STEREO_CAMERAS",)))
    model = onnx.load_from_string(export_onnx(network))
    assert [[d.dim_value for d in i.type.tensor_type.shape.dim] for i in model.graph.input] == [[1, 120, 160, 2]]


def test_retention_keeps_four_newest_plus_best(tmp_path):
    store = LocalStore(tmp_path)
    checkpoints = CheckpointStore(store, PREFIX)
    torch.manual_seed(0)
    network = build_actor_critic(small_metadata(sensors=("FRONT_FACING_CAMERA",)))
    names = []
    for number in range(7):
        names.append(checkpoints.save(number, 100 * number, network))
        if number == 1:
            checkpoints.record_evaluation(names[1], avg_eval_metric=80.0, time_stamp=10.0)
        elif number > 1:
            checkpoints.record_evaluation(names[-1], avg_eval_metric=10.0 * number, time_stamp=10.0 * number)
    assert checkpoints.read_best_and_last().best.name == "1_Step-100.ckpt"
    assert checkpoints.names() == [
        "1_Step-100.ckpt",
        "3_Step-300.ckpt",
        "4_Step-400.ckpt",
        "5_Step-500.ckpt",
        "6_Step-600.ckpt",
    ]
    keys = store.list_keys(f"{PREFIX}/model/")
    for deleted in ("0_Step-0.ckpt", "2_Step-200.ckpt"):
        assert not [key for key in keys if deleted in key]
    assert sorted(key.rsplit("/", 1)[1] for key in keys if key.endswith(".onnx")) == [
        "model_1.onnx",
        "model_3.onnx",
        "model_4.onnx",
        "model_5.onnx",
        "model_6.onnx",
    ]
    assert checkpoints.latest_name() == "6_Step-600.ckpt"

    # When a newer checkpoint becomes best, the old best is no longer protected.
    checkpoints.record_evaluation("6_Step-600.ckpt", avg_eval_metric=95.0, time_stamp=70.0)
    checkpoints.save(7, 700, network)
    assert checkpoints.names() == ["4_Step-400.ckpt", "5_Step-500.ckpt", "6_Step-600.ckpt", "7_Step-700.ckpt"]


class RecordingStore(LocalStore):
    """A LocalStore that checks, after every write or delete, that the pointer names a loadable checkpoint."""

    def __init__(self, root, fail_after_puts: int | None = None):
        super().__init__(root)
        self.fail_after_puts = fail_after_puts
        self.puts = 0
        self.checks = 0
        self.operations: list[str] = []

    def put_bytes(self, key, data):
        if self.fail_after_puts is not None and self.puts >= self.fail_after_puts:
            raise ConnectionError("store went away mid-upload")
        self.puts += 1
        super().put_bytes(key, data)
        self.operations.append(f"put {key.rsplit('/', 1)[-1]}")
        self.check_pointer()

    def delete(self, key):
        super().delete(key)
        self.operations.append(f"delete {key.rsplit('/', 1)[-1]}")
        self.check_pointer()

    def check_pointer(self):
        pointer_key = f"{PREFIX}/model/.coach_checkpoint"
        if not self.exists(pointer_key):
            return
        name = self.get_bytes(pointer_key).decode().strip()
        manifest = json.loads(self.get_bytes(f"{PREFIX}/model/{name}.json"))
        for file_name in manifest["files"]:
            assert self.exists(f"{PREFIX}/model/{file_name}"), f"pointer names {name} but {file_name} is missing"
        self.checks += 1


def test_pointer_never_names_a_checkpoint_whose_files_are_missing(tmp_path):
    store = RecordingStore(tmp_path)
    checkpoints = CheckpointStore(store, PREFIX, keep=2)
    torch.manual_seed(0)
    network = build_actor_critic(small_metadata(sensors=("FRONT_FACING_CAMERA",)))
    for number in range(5):
        checkpoints.save(number, number, network)  # retention deletes on every save from the third on
    assert store.checks > 20
    first_save = store.operations[: store.operations.index("put .coach_checkpoint") + 1]
    assert first_save[0] == "put .lock" and first_save[-2] == "put 0_Step-0.ckpt.json"  # manifest just before pointer
    assert store.operations[len(first_save)] == "delete .lock"


def test_an_interrupted_save_leaves_the_previous_checkpoint_in_place(tmp_path):
    torch.manual_seed(0)
    network = build_actor_critic(small_metadata(sensors=("FRONT_FACING_CAMERA",)))
    batch = observation_batch(network, seed=6)
    CheckpointStore(LocalStore(tmp_path), PREFIX).save(0, 10, network)
    expected = outputs(network, batch)
    with torch.no_grad():
        network.policy_head.bias.add_(1.0)
    for fail_after in range(1, 4):  # dies after the lock, after the weights, after the onnx file
        store = RecordingStore(tmp_path, fail_after_puts=fail_after)
        with pytest.raises(ConnectionError):
            CheckpointStore(store, PREFIX).save(1, 20, network)
        checkpoints = CheckpointStore(LocalStore(tmp_path), PREFIX)
        assert checkpoints.latest_name() == "0_Step-10.ckpt" and checkpoints.names() == ["0_Step-10.ckpt"]
        assert all(torch.equal(a, b) for a, b in zip(outputs(checkpoints.load_policy(), batch), expected, strict=True))
    assert CheckpointStore(LocalStore(tmp_path), PREFIX).is_locked()  # a dead upload leaves its lock, as in DeepRacer
    CheckpointStore(LocalStore(tmp_path), PREFIX).save(1, 20, network)
    assert not CheckpointStore(LocalStore(tmp_path), PREFIX).is_locked()


def test_corrupt_or_missing_files_are_reported(tmp_path):
    store = LocalStore(tmp_path)
    checkpoints = CheckpointStore(store, PREFIX)
    torch.manual_seed(0)
    name = checkpoints.save(0, 1, build_actor_critic(small_metadata(sensors=("FRONT_FACING_CAMERA",))))
    key = f"{PREFIX}/model/{name}.weights.safetensors"
    data = bytearray(store.get_bytes(key))
    data[-1] ^= 0xFF
    store.put_bytes(key, bytes(data))
    with pytest.raises(CheckpointError, match="does not match its manifest"):
        checkpoints.load_policy()
    store.delete(key)
    with pytest.raises(CheckpointError, match="is missing"):
        checkpoints.load(name)
    with pytest.raises(CheckpointError, match="no manifest"):
        checkpoints.load("7_Step-9.ckpt")
    with pytest.raises(CheckpointError, match="nothing to load"):
        CheckpointStore(store, "other-run").load_policy()


def test_best_and_last_follow_deepracer_rules(tmp_path):
    store = LocalStore(tmp_path)
    checkpoints = CheckpointStore(store, PREFIX)
    assert checkpoints.read_best_and_last() is None
    checkpoints.record_evaluation("1_Step-10.ckpt", 50.0, 1.5)
    result = checkpoints.record_evaluation("2_Step-20.ckpt", 50.0, 2.5)  # tie -> newer
    assert result.best.name == "2_Step-20.ckpt"
    result = checkpoints.record_evaluation("3_Step-30.ckpt", 40.0, 3.5)
    assert result.best.name == "2_Step-20.ckpt" and result.last.name == "3_Step-30.ckpt"
    data = json.loads(store.get_bytes(f"{PREFIX}/model/deepracer_checkpoints.json"))
    assert data == {
        "best_checkpoint": {"name": "2_Step-20.ckpt", "avg_eval_metric": 50.0, "time_stamp": 2.5},
        "last_checkpoint": {"name": "3_Step-30.ckpt", "avg_eval_metric": 40.0, "time_stamp": 3.5},
    }
    # Lap time: lower is better.
    other = CheckpointStore(store, "laps")
    other.record_evaluation("1_Step-10.ckpt", 12000.0, 1.0, higher_is_better=False)
    assert other.record_evaluation("2_Step-20.ckpt", 11000.0, 2.0, higher_is_better=False).best.name == "2_Step-20.ckpt"
    # Older DRfC files carry avg_comp_pct instead of avg_eval_metric.
    store.put_bytes(
        "old/model/deepracer_checkpoints.json",
        b'{"best_checkpoint": {"name": "4_Step-9.ckpt", "avg_comp_pct": 71.5, "time_stamp": 3}}',
    )
    old = CheckpointStore(store, "old").read_best_and_last()
    assert old.best == CheckpointRecord("4_Step-9.ckpt", 71.5, 3.0) and old.last is None


def test_model_metadata_and_hyperparameters_files(tmp_path):
    store = LocalStore(tmp_path)
    checkpoints = CheckpointStore(store, PREFIX)
    md = small_metadata()
    checkpoints.put_model_metadata(md)
    checkpoints.put_hyperparameters(replace(HP, lr=0.001))
    assert parse_model_metadata(json.loads(store.get_bytes(f"{PREFIX}/model/model_metadata.json"))) == md
    assert json.loads(store.get_bytes(f"{PREFIX}/ip/hyperparameters.json"))["lr"] == 0.001


def test_restore_select_and_names(tmp_path):
    store = LocalStore(tmp_path)
    checkpoints = CheckpointStore(store, PREFIX)
    with pytest.raises(CheckpointError, match="no checkpoint"):
        checkpoints.select("last")
    learner, episodes = trained(seed=6)
    assert checkpoints.save(0, 0, learner.network, learner.optimizer) == "0_Step-0.ckpt"
    learner.update(episodes)
    assert checkpoints.save(1, 519, learner.network, learner.optimizer) == "1_Step-519.ckpt"
    assert CheckpointName.parse(checkpoints.latest_name()) == CheckpointName(1, 519)
    assert checkpoints.select("last") == checkpoints.select("best") == "1_Step-519.ckpt"
    checkpoints.record_evaluation("0_Step-0.ckpt", 70.0, 1.0)
    checkpoints.record_evaluation("1_Step-519.ckpt", 60.0, 2.0)
    assert checkpoints.select("best") == "0_Step-0.ckpt" and checkpoints.select("0_Step-0.ckpt") == "0_Step-0.ckpt"
    with pytest.raises(CheckpointError, match="have 0_Step-0.ckpt, 1_Step-519.ckpt"):
        checkpoints.select("5_Step-9.ckpt")
    with pytest.raises(ValueError, match="checkpoint name"):
        CheckpointName.parse("model.ckpt")

    torch.manual_seed(11)
    fresh = build_actor_critic(small_metadata())
    fresh_learner = PPOLearner(fresh, HP, PPOSettings(seed=0))
    assert checkpoints.restore("1_Step-519.ckpt", fresh, fresh_learner.optimizer) == (1, 519)
    batch = observation_batch(fresh, seed=7)
    assert all(torch.equal(a, b) for a, b in zip(outputs(fresh, batch), outputs(learner.network, batch), strict=True))
    assert (
        fresh_learner.optimizer.state_dict()["state"][0]["step"] == learner.optimizer.state_dict()["state"][0]["step"]
    )
    weights_only = build_actor_critic(small_metadata())
    assert checkpoints.restore("0_Step-0.ckpt", weights_only) == (0, 0)
    other = build_actor_critic(small_metadata(continuous=True))
    with pytest.raises(CheckpointError, match="different network"):
        checkpoints.restore("0_Step-0.ckpt", other)
