"""SAC as DeepRacer configures it: networks, replay memory, the update, checkpoints and the exported policy."""

from __future__ import annotations

import copy
import json
import logging
import math

import numpy as np
import pytest
import torch

from benchmarks.sac import plain_sac_step, synthetic_episodes
from racer.shared.config import LocalStoreSettings
from racer.shared.deepracer.hyperparameters import Hyperparameters, load_hyperparameters
from racer.shared.deepracer.model_metadata import load_model_metadata, parse_model_metadata
from racer.shared.episode import Episode
from racer.shared.policy.checkpoints import CheckpointStore
from racer.shared.policy.factory import build_network, build_network_for_metadata
from racer.shared.policy.networks import InputSpec, PolicyConfig, policy_config_from_metadata
from racer.shared.policy.onnx_policy import SacOnnxPolicy
from racer.shared.policy.sac_networks import SACNetworks, squashed_gaussian_log_prob
from racer.shared.store import open_store
from racer.trainer.precision import Precision
from racer.trainer.replay_buffer import ReplayBuffer, bytes_per_transition
from racer.trainer.sac import SACLearner, SACSettings, sac_minibatch_size

LIDAR_ONLY = PolicyConfig(
    neural_network="DEEP_CONVOLUTIONAL_NETWORK_SHALLOW",
    inputs=(InputSpec("LIDAR", "vector", (64,)),),
    action_space_type="continuous",
    num_actions=2,
    training_algorithm="sac",
)
SAC_METADATA = {
    "action_space": {"steering_angle": {"low": -30, "high": 30}, "speed": {"low": 1, "high": 2}},
    "action_space_type": "continuous",
    "training_algorithm": "sac",
    "sensor": ["FRONT_FACING_CAMERA"],
    "neural_network": "DEEP_CONVOLUTIONAL_NETWORK_SHALLOW",
    "version": "5",
}
TARGET_ACTION = np.array([0.5, -0.3], dtype=np.float32)


def bandit_episodes(networks: SACNetworks, count: int, rng: np.random.Generator) -> list[Episode]:
    """One-step episodes: reward 1 - |a - target|^2 whatever the observation, actions sampled from the policy."""
    lidar = rng.uniform(0.15, 1.0, (count, 64)).astype(np.float32)
    with torch.no_grad():
        actions = networks.sample({"LIDAR": torch.from_numpy(lidar)}).action.numpy()
    rewards = 1.0 - np.square(actions - TARGET_ACTION).sum(axis=1)
    return [
        Episode(
            observations={"LIDAR": lidar[i : i + 1]},
            actions=actions[i : i + 1],
            rewards=rewards[i : i + 1].astype(np.float32),
            log_probs=np.zeros(1, np.float32),
            policy_version=0,
            worker_id=0,
            world="base",
        )
        for i in range(count)
    ]


def test_three_networks_on_deepracers_embedders_none_sharing_a_weight():
    config = policy_config_from_metadata(parse_model_metadata(SAC_METADATA))
    networks = build_network(config)
    assert isinstance(networks, SACNetworks)
    # Policy and V: embedders + the shallow middleware Dense(512); Q: embedders only (11264 conv features).
    assert networks.policy_tower.out_features == 512 and networks.value_tower.out_features == 512
    assert networks.q_tower.out_features == 11264
    assert networks.q_head.q1[0].in_features == 11264 + 2
    assert networks.policy_head.hidden.out_features == 256
    pointers = {}
    for name, parameter in networks.named_parameters():
        assert parameter.data_ptr() not in pointers, f"{name} shares storage with {pointers.get(parameter.data_ptr())}"
        pointers[parameter.data_ptr()] = name
    assert not any(p.requires_grad for p in networks.target_value_tower.parameters())
    trainable = {id(p) for p in networks.trainable_parameters()}
    assert all(id(p) not in trainable for p in networks.target_value_head.parameters())


def test_users_sac_files_build_their_networks(deepracer_data):
    for name in (
        "dots_model_metadata_sac.json",
        "dpr401_model_metadata_front_shallow_continuous_sac.json",
        "drfc_defaults_model_metadata_sac.json",
    ):
        networks = build_network_for_metadata(load_model_metadata(deepracer_data / "config" / name))
        assert isinstance(networks, SACNetworks)
    stereo = build_network_for_metadata(load_model_metadata(deepracer_data / "config" / "dots_model_metadata_sac.json"))
    assert stereo.config.inputs[0].shape == (120, 160, 2)
    hyperparameters, warnings = load_hyperparameters(deepracer_data / "config" / "dots_hyperparameters_sac.json")
    assert (hyperparameters.sac_alpha, hyperparameters.batch_size, hyperparameters.loss_type) == (
        0.2,
        64,
        "mean squared error",
    )
    assert warnings == []


def test_squashed_log_prob_matches_the_change_of_variables():
    mean, log_std = torch.tensor([[0.3, -1.2]]), torch.tensor([[-0.5, 0.2]])
    raw = torch.tensor([[0.1, -0.4]])
    action = torch.tanh(raw)
    expected = torch.distributions.Normal(mean, log_std.exp()).log_prob(raw).sum() - torch.log(1 - action**2).sum()
    assert float(squashed_gaussian_log_prob(raw, action, mean, log_std)) == pytest.approx(float(expected), abs=1e-5)


def test_replay_memory_is_sized_by_bytes_and_keeps_successors(episode_factory):
    inputs = (InputSpec("FRONT_FACING_CAMERA", "camera", (120, 160, 1)),)
    per_transition = bytes_per_transition(inputs)
    assert per_transition == 19200 + 8 + 4 + 1
    replay = ReplayBuffer(inputs, 25 * per_transition)
    assert replay.capacity == 25
    episodes = [episode_factory(10, seed=s, continuous=True) for s in range(3)]  # 30 steps: the first 5 are gone
    for episode in episodes:
        replay.add_episode(episode)
    assert len(replay) == 25
    batch = replay.sample(400, np.random.default_rng(0))
    frames = np.concatenate([e.observations["FRONT_FACING_CAMERA"] for e in episodes])[5:]
    index = {frame.tobytes(): i for i, frame in enumerate(frames)}
    for i in range(400):
        position = index[batch.observations["FRONT_FACING_CAMERA"][i].numpy().tobytes()]
        ends_episode = (position + 5) % 10 == 9
        assert float(batch.dones[i]) == float(ends_episode)
        if not ends_episode:  # the stored successor is the next frame of the same episode
            assert np.array_equal(batch.next_observations["FRONT_FACING_CAMERA"][i].numpy(), frames[position + 1])


def test_minibatch_follows_deepracers_rule():
    assert sac_minibatch_size(replay_transitions=1000, iteration_transitions=300, batch_size=64) == 64
    assert sac_minibatch_size(replay_transitions=50, iteration_transitions=50, batch_size=64) == 32


@pytest.mark.slow
def test_sac_learns_a_one_step_task():
    torch.manual_seed(0)
    networks = SACNetworks(LIDAR_ONLY)
    learner = SACLearner(
        networks,
        Hyperparameters(batch_size=64, lr=3e-3, sac_alpha=0.01),
        SACSettings(replay_memory_bytes=8 << 20, seed=0, updates_per_transition=1.0),
    )
    rng = np.random.default_rng(0)
    probe = {"LIDAR": torch.from_numpy(rng.uniform(0.15, 1.0, (64, 64)).astype(np.float32))}
    with torch.no_grad():
        before = float(np.square(networks.policy_output(probe).numpy() - TARGET_ACTION).sum(axis=1).mean())
    target_before = [p.clone() for p in networks.target_value_head.parameters()]
    stats = []
    for _ in range(6):
        stats += learner.update(bandit_episodes(networks, 80, rng))
    with torch.no_grad():
        after = float(np.square(networks.policy_output(probe).numpy() - TARGET_ACTION).sum(axis=1).mean())
    assert stats[0].gradient_steps == 80 and stats[0].minibatch_size == 64
    assert after < 0.05 < before
    assert all(math.isfinite(s.q_loss) for s in stats)
    # The target V was synced from V (once per iteration), so it moved.
    assert any(
        not torch.equal(a, b) for a, b in zip(target_before, networks.target_value_head.parameters(), strict=True)
    )


def _value_weights(networks: SACNetworks, target: bool) -> list[torch.Tensor]:
    tower, head = (
        (networks.target_value_tower, networks.target_value_head)
        if target
        else (networks.value_tower, networks.value_head)
    )
    return [p.detach().clone() for p in (*tower.parameters(), *head.parameters())]


def test_target_v_is_copied_once_per_update_after_its_first_step():
    """DeepRacer's rule, from RL Coach's Agent.train: the trainer's step counter moves only while the episodes are
    fetched (one `act` per transition), `num_steps_between_copying_online_weights_to_target` is
    EnvironmentSteps(num_episodes_between_training) and the copy rate is 1, so V_target = V after the first
    gradient step of every training call and not again until the next one."""
    torch.manual_seed(5)
    settings = SACSettings(replay_memory_bytes=4 << 20, seed=5, threads_per_tower=1, precision=Precision.FP32)
    one_step = SACLearner(SACNetworks(LIDAR_ONLY), Hyperparameters(batch_size=32, lr=1e-3), settings)
    three_steps = SACLearner(copy.deepcopy(one_step.networks), one_step.hyperparameters, settings)
    episodes = bandit_episodes(one_step.networks, 40, np.random.default_rng(5))
    for learner in (one_step, three_steps):
        learner.add_experience(episodes)
    one_step._train(1, 32)
    three_steps._train(3, 32)
    after_first_step = _value_weights(one_step.networks, target=False)
    for a, b in zip(_value_weights(one_step.networks, target=True), after_first_step, strict=True):
        torch.testing.assert_close(a, b, rtol=0, atol=0)
    for a, b in zip(_value_weights(three_steps.networks, target=True), after_first_step, strict=True):
        torch.testing.assert_close(a, b, rtol=1e-5, atol=1e-7)
    # Steps 2 and 3 moved V but not its target.
    moved = _value_weights(three_steps.networks, target=False)
    assert any(not torch.allclose(a, b) for a, b in zip(moved, after_first_step, strict=True))


def test_two_thread_step_computes_the_plain_sequential_step():
    """The trainer's step (towers on two threads, Q head held constant in the policy loss) moves every weight as
    the textbook step does, from the same weights, minibatch and noise."""
    torch.manual_seed(3)
    networks = build_network_for_metadata(parse_model_metadata(SAC_METADATA))
    settings = SACSettings(replay_memory_bytes=4 << 20, seed=3, threads_per_tower=1, precision=Precision.FP32)
    hyperparameters = Hyperparameters(batch_size=8, lr=1e-3, loss_type="huber")
    fast = SACLearner(networks, hyperparameters, settings)
    plain = SACLearner(copy.deepcopy(networks), hyperparameters, settings)
    episodes = synthetic_episodes(2, 12, seed=3)
    for learner in (fast, plain):
        learner.add_experience(episodes)
    before = {name: p.detach().clone() for name, p in networks.named_parameters()}
    fast._train(1, 8)
    plain_sac_step(plain, plain.replay.sample(8, plain.rng))
    plain.networks.sync_target()  # as _train does after an iteration's first step
    moved = 0
    for (name, a), (_, b) in zip(fast.networks.named_parameters(), plain.networks.named_parameters(), strict=True):
        torch.testing.assert_close(a, b, rtol=1e-4, atol=1e-6, msg=name)
        moved += not torch.equal(a, before[name])
    assert moved == len(before)  # every weight took the step (the target V by its copy of V)


@pytest.mark.parametrize("loss_type", ["mean squared error", "huber"])
def test_step_gradients_and_losses_are_the_textbook_steps(loss_type):
    """Every speed-up of the trainer's step keeps the arithmetic: over three steps from the same weights, minibatches
    and noise, each weight's gradient (left in `.grad` by the step) and each loss equal the plain sequential step's
    to float tolerance. Gradients, unlike weights after an Adam step, carry their size, so a lost term shows."""
    torch.manual_seed(4)
    networks = build_network_for_metadata(parse_model_metadata(SAC_METADATA))
    settings = SACSettings(replay_memory_bytes=4 << 20, seed=4, threads_per_tower=1, precision=Precision.FP32)
    hyperparameters = Hyperparameters(batch_size=16, lr=1e-3, loss_type=loss_type)
    fast = SACLearner(networks, hyperparameters, settings)
    plain = SACLearner(copy.deepcopy(networks), hyperparameters, settings)
    episodes = synthetic_episodes(2, 30, seed=4)
    for learner in (fast, plain):
        learner.add_experience(episodes)
    for step in range(3):
        stats = fast._train(1, 16)
        expected = plain_sac_step(plain, plain.replay.sample(16, plain.rng))
        plain.networks.sync_target()  # as _train does after every call's first step
        for key, value in (("policy", stats.policy_loss), ("q", stats.q_loss), ("v", stats.value_loss)):
            assert value == pytest.approx(expected[key], rel=1e-5, abs=1e-6), (step, key)
        assert stats.entropy == pytest.approx(expected["entropy"], rel=1e-5, abs=1e-6)
        assert stats.mean_q == pytest.approx(expected["mean_q"], rel=1e-5, abs=1e-6)
        for (name, a), (_, b) in zip(fast.networks.named_parameters(), plain.networks.named_parameters(), strict=True):
            if not a.requires_grad:
                continue
            assert a.grad is not None and b.grad is not None, name
            scale = float(b.grad.abs().max())
            torch.testing.assert_close(a.grad, b.grad, rtol=1e-4, atol=1e-5 * scale + 1e-12, msg=f"{name} {step}")
            torch.testing.assert_close(a, b, rtol=1e-4, atol=1e-6, msg=f"{name} {step}")


def test_non_finite_weights_roll_back_and_halve_the_learning_rate(caplog):
    torch.manual_seed(1)
    networks = SACNetworks(LIDAR_ONLY)
    learner = SACLearner(networks, Hyperparameters(lr=3e-4), SACSettings(replay_memory_bytes=4 << 20, seed=1))
    rng = np.random.default_rng(1)
    learner.update(bandit_episodes(networks, 40, rng))
    good = {k: v.clone() for k, v in networks.state_dict().items()}
    with torch.no_grad():
        networks.q_head.q1[0].weight[0, 0] = float("nan")
    with caplog.at_level(logging.WARNING, logger="racer.trainer.sac"):
        learner.update(bandit_episodes(networks, 40, rng))
    assert "weights were not finite" in caplog.text
    assert learner.learning_rate == pytest.approx(1.5e-4)
    assert learner.nan_rollbacks == 1
    assert all(torch.isfinite(v).all() for v in networks.state_dict().values())
    assert any(not torch.equal(good[k], v) for k, v in networks.state_dict().items())  # trained on after the rollback


def test_checkpoint_round_trip_and_the_exported_policy(tmp_path):
    torch.manual_seed(2)
    metadata = parse_model_metadata(SAC_METADATA)
    networks = build_network_for_metadata(metadata)
    learner = SACLearner(networks, Hyperparameters(), SACSettings(replay_memory_bytes=16 << 20, seed=2))
    rng = np.random.default_rng(2)
    frames = rng.integers(0, 255, (6, 120, 160, 1), dtype=np.uint8)
    actions = rng.uniform(-1, 1, (6, 2)).astype(np.float32)
    episode = Episode(
        observations={"FRONT_FACING_CAMERA": frames},
        actions=actions,
        rewards=np.ones(6, np.float32),
        log_probs=np.zeros(6, np.float32),
        policy_version=0,
        worker_id=0,
        world="base",
    )
    learner.update([episode])
    store = open_store(LocalStoreSettings(root=tmp_path))
    checkpoints = CheckpointStore(store, "sac-model")
    name = checkpoints.save(1, 6, networks, learner.optimizer, metadata, Hyperparameters())

    manifest = json.loads(store.get_bytes(f"sac-model/model/{name}.json"))
    assert manifest["policy_config"]["training_algorithm"] == "sac"
    assert "sac_alpha" in manifest["hyperparameters"] and "num_epochs" not in manifest["hyperparameters"]
    restored = build_network_for_metadata(metadata)
    fresh = SACLearner(restored, Hyperparameters(), SACSettings(replay_memory_bytes=16 << 20))
    assert checkpoints.restore(name, restored, fresh.optimizer) == (1, 6)
    for (key, a), b in zip(networks.state_dict().items(), restored.state_dict().values(), strict=True):
        assert torch.equal(a, b), key
    assert isinstance(checkpoints.load_policy(name), SACNetworks)

    exported = checkpoints.load_inference_policy(name)
    assert isinstance(exported, SacOnnxPolicy)
    observation = {"FRONT_FACING_CAMERA": frames[0]}
    greedy, _ = exported.act(observation, greedy=True)
    with torch.no_grad():
        expected = networks.eval().policy_output({"FRONT_FACING_CAMERA": torch.from_numpy(frames[:1])})[0].numpy()
    np.testing.assert_allclose(greedy, expected, atol=1e-5)
    again, _ = exported.act(observation, greedy=True)
    np.testing.assert_array_equal(greedy, again)  # evaluation drives the mean: deterministic
    sampled = [exported.act(observation, greedy=False, generator=np.random.default_rng(s))[0] for s in range(20)]
    assert np.all(np.abs(sampled) <= 1.0) and np.std(sampled, axis=0).min() > 1e-3
