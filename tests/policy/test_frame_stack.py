"""Frame stacking (hyperparameters.json stack_size > 1, racer.shared.policy.frame_stack): RL Coach's
ObservationStackingFilter semantics (the first frame of an episode fills the stack, then a sliding window, newest
last on the channel axis), the worker's step-by-step stacks equal the trainer's stacks rebuilt from an episode's
single frames, networks take N channels, and a stack_size 1 model is what it was (no stack_size in its manifest)."""

from __future__ import annotations

import numpy as np
import pytest

from racer.shared.deepracer.hyperparameters import HyperparametersError, parse_hyperparameters
from racer.shared.deepracer.model_metadata import parse_model_metadata
from racer.shared.policy.factory import build_network_for_metadata
from racer.shared.policy.frame_stack import FrameStacker, frame_stacker_for, stack_episode_frames
from racer.shared.policy.policy_config import PolicyConfig, policy_config_from_metadata
from racer.shared.run_settings import RunOptions

METADATA = {
    "action_space": [{"steering_angle": angle, "speed": 1.0} for angle in (-30, 0, 30)],
    "sensor": ["FRONT_FACING_CAMERA", "SECTOR_LIDAR"],
    "neural_network": "DEEP_CONVOLUTIONAL_NETWORK_SHALLOW",
    "training_algorithm": "clipped_ppo",
    "version": "5",
}


def frames(steps: int, channels: int = 1) -> np.ndarray:
    """Frame t is filled with t * 10 + channel."""
    values = np.arange(steps)[:, None] * 10 + np.arange(channels)[None, :]
    return np.broadcast_to(values[:, None, None, :], (steps, 4, 5, channels)).astype(np.uint8)


def channel_values(stacked: np.ndarray) -> list[int]:
    return [int(value) for value in stacked[..., 0, 0, :].reshape(-1)]


def test_reset_repeats_the_first_frame_then_the_window_slides():
    episode = frames(5)
    stacker = FrameStacker(3, ["cam"])
    seen = [stacker.reset({"cam": episode[0], "lidar": np.ones(8)})]
    seen += [stacker.push({"cam": frame, "lidar": np.ones(8)}) for frame in episode[1:]]
    assert [channel_values(item["cam"]) for item in seen] == [
        [0, 0, 0],
        [0, 0, 10],
        [0, 10, 20],
        [10, 20, 30],
        [20, 30, 40],
    ]
    assert all(item["cam"].shape == (4, 5, 3) and item["cam"].dtype == np.uint8 for item in seen)
    assert all(np.array_equal(item["lidar"], np.ones(8)) for item in seen)  # LIDAR is not stacked
    again = stacker.reset({"cam": episode[4]})  # a new episode forgets the last one
    assert channel_values(again["cam"]) == [40, 40, 40]


def test_the_trainer_rebuilds_the_workers_stacks_from_single_frames():
    for channels in (1, 2):  # 2: STEREO_CAMERAS, frame by frame (left, right of the oldest, ... of the newest)
        episode = frames(6, channels)
        stacker = FrameStacker(2, ["cam"])
        online = [stacker.reset({"cam": episode[0]})["cam"]] + [stacker.push({"cam": f})["cam"] for f in episode[1:]]
        rebuilt = stack_episode_frames(episode, 2)
        assert rebuilt.shape == (6, 4, 5, 2 * channels)
        np.testing.assert_array_equal(rebuilt, np.stack(online))
    assert channel_values(stack_episode_frames(frames(3, 2), 2)[2]) == [10, 11, 20, 21]
    assert stack_episode_frames(frames(3), 1) is not None and stack_episode_frames(frames(0), 4).shape == (0, 4, 5, 4)


def test_stack_size_is_a_hyperparameter_from_1_to_8():
    assert parse_hyperparameters({"stack_size": 2}, "h.json")[0].stack_size == 2
    with pytest.raises(HyperparametersError, match="stack_size"):
        parse_hyperparameters({"stack_size": 0}, "h.json")


def test_a_stack_size_2_network_takes_two_frames_and_lidar_unstacked():
    metadata = parse_model_metadata(METADATA, "model_metadata.json")
    config = policy_config_from_metadata(metadata, stack_size=2)
    assert {spec.name: spec.shape for spec in config.inputs} == {
        "FRONT_FACING_CAMERA": (120, 160, 2),
        "SECTOR_LIDAR": (8,),
    }
    network = build_network_for_metadata(metadata, stack_size=2)
    assert network.policy_tower.embedders["FRONT_FACING_CAMERA"].convs[0].in_channels == 2
    assert PolicyConfig.from_dict(config.to_dict()) == config and config.to_dict()["stack_size"] == 2
    stacker = frame_stacker_for(network)
    assert stacker is not None and stacker.names == ("FRONT_FACING_CAMERA",)
    observation = {"FRONT_FACING_CAMERA": np.zeros((120, 160, 1), np.uint8), "SECTOR_LIDAR": np.zeros(8, np.float32)}
    action, _ = network.act(stacker.reset(observation), greedy=True)
    assert 0 <= int(action) < 3


def test_stack_size_1_is_unchanged():
    metadata = parse_model_metadata(METADATA, "model_metadata.json")
    config = policy_config_from_metadata(metadata)
    assert config.stack_size == 1 and "stack_size" not in config.to_dict()  # manifests as before
    assert dict((spec.name, spec.shape) for spec in config.inputs)["FRONT_FACING_CAMERA"] == (120, 160, 1)
    assert frame_stacker_for(build_network_for_metadata(metadata)) is None  # observations go in untouched
    stereo = parse_model_metadata({**METADATA, "sensor": ["STEREO_CAMERAS"]}, "model_metadata.json")
    stacked_stereo = policy_config_from_metadata(stereo, stack_size=2)
    assert stacked_stereo.inputs[0].shape == (120, 160, 4)
    assert stacked_stereo.embedder_layers(stacked_stereo.inputs[0]) == policy_config_from_metadata(
        stereo
    ).embedder_layers(policy_config_from_metadata(stereo).inputs[0])  # still the stereo embedder


def test_a_stack_size_2_model_trains_an_iteration_and_evaluates(tmp_path, redis_settings):
    """Worker (play_episode, stacked online) -> wire (single frames) -> trainer (stacked again) -> checkpoint whose
    ONNX model declares two channels -> `racer evaluate`'s session drives it."""
    import json

    from racer.evaluation_worker.config import DeepRacerRules, EvaluationConfig, VideoOptions
    from racer.evaluation_worker.runner import EvaluationSession
    from racer.shared.config import LocalStoreSettings
    from racer.shared.policy.checkpoints import CheckpointStore
    from racer.shared.store import open_store
    from racer.trainer.preflight import preflight
    from tests.trainer.test_preflight import (
        DEFAULT_HYPERPARAMETERS,
        DEFAULT_METADATA,
        custom_files_from,
        train_one_iteration,
    )

    folder = custom_files_from(tmp_path, DEFAULT_METADATA, DEFAULT_HYPERPARAMETERS)
    hyperparameters = json.loads((folder / "hyperparameters.json").read_text())
    (folder / "hyperparameters.json").write_text(json.dumps({**hyperparameters, "stack_size": 2}))
    report = preflight(folder, RunOptions(1, "racer_oval", ("base",)))
    assert report.hyperparameters.stack_size == 2
    train_one_iteration(folder, report, tmp_path, redis_settings)
    store = open_store(LocalStoreSettings(root=tmp_path / "store"))
    checkpoints = CheckpointStore(store, "pair")
    policy = checkpoints.load_inference_policy()
    assert policy.config.stack_size == 2
    camera = [spec for spec in policy.config.inputs if spec.kind == "camera"]
    assert camera and all(spec.shape[2] == 2 for spec in camera)
    assert [tuple(d.dim_value for d in i.type.tensor_type.shape.dim)[1:] for i in _onnx_inputs(checkpoints)] == [
        spec.shape for spec in policy.config.inputs
    ]

    config = EvaluationConfig(
        model_prefix="pair",
        mode="deepracer",
        track="racer_oval",
        world="base",
        deepracer=DeepRacerRules(number_of_trials=1, number_of_resets=0),
        video=VideoOptions(enabled=False),
    )
    evaluation = EvaluationSession(store, config, out_dir=tmp_path / "eval").run()
    assert evaluation is not None


def _onnx_inputs(checkpoints):
    import onnx

    from racer.shared import model_layout

    info = checkpoints.read_info(checkpoints.latest_name())
    onnx_file = model_layout.inference_model(info.number, "onnx").removeprefix(model_layout.MODEL_DIR + "/")
    return onnx.load_from_string(checkpoints._read_verified(info, onnx_file)).graph.input


def test_sac_replay_memory_stores_stacked_frames_from_single_frame_episodes():
    from racer.shared.episode import Episode
    from racer.shared.policy.policy_config import InputSpec
    from racer.trainer.replay_buffer import ReplayBuffer

    steps = 4
    episode = Episode(
        observations={"cam": frames(steps)},
        actions=np.zeros((steps, 2), np.float32),
        rewards=np.ones(steps, np.float32),
        log_probs=np.zeros(steps, np.float32),
        policy_version=0,
        worker_id=0,
        world="base",
        episode_index=0,
        final_status="off_track",
        progress=1.0,
    )
    replay = ReplayBuffer((InputSpec("cam", "camera", (4, 5, 2)),), 10_000, stack_size=2)
    replay.add_episode(episode)
    batch = replay.sample(16, np.random.default_rng(0))
    for observation, successor, done in zip(
        batch.observations["cam"].numpy(), batch.next_observations["cam"].numpy(), batch.dones.numpy(), strict=True
    ):
        older, newer = channel_values(observation)
        assert older == max(newer - 10, 0)
        if not done:
            assert channel_values(successor) == [newer, newer + 10]
