"""The three DeepRacer network types: layer sizes of deepracer-simapp v5.3.3 `bundle/markov/sensors/utils.py`, heads,
and single-observation acting."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from racer.shared.deepracer.model_metadata import load_model_metadata, parse_model_metadata
from racer.shared.policy.networks import (
    E_GREEDY_EVALUATION_EPSILON,
    NETWORK_ARCHITECTURES,
    ActorCritic,
    CameraEmbedder,
    CategoricalPolicy,
    GaussianPolicy,
    InputSpec,
    PolicyConfig,
    build_actor_critic,
    conv_output_shape,
    e_greedy_epsilon,
    policy_config_from_metadata,
    sample_categorical,
    select_action,
)

FRONT = InputSpec("FRONT_FACING_CAMERA", "camera", (120, 160, 1))
FIVE_ACTIONS = [{"steering_angle": angle, "speed": 1.0} for angle in (-30, -15, 0, 15, 30)]
CONTINUOUS = {"steering_angle": {"low": -30, "high": 30}, "speed": {"low": 0.5, "high": 2.0}}


def metadata(sensors, network="DEEP_CONVOLUTIONAL_NETWORK_SHALLOW", action_space=None, **extra):
    data = {"action_space": action_space or FIVE_ACTIONS, "sensor": sensors, "neural_network": network, "version": "5"}
    if isinstance(action_space, dict):
        data["action_space_type"] = "continuous"
    data.update(extra)
    return parse_model_metadata(data)


def random_observation(config: PolicyConfig, rng: np.random.Generator) -> dict[str, np.ndarray]:
    observation = {}
    for spec in config.inputs:
        if spec.kind == "camera":
            observation[spec.name] = rng.integers(0, 256, size=spec.shape, dtype=np.uint8)
        else:
            observation[spec.name] = rng.uniform(0.15, 1.0, size=spec.shape).astype(np.float32)
    return observation


def batch_of(observations: list[dict[str, np.ndarray]]) -> dict[str, torch.Tensor]:
    return {name: torch.from_numpy(np.stack([obs[name] for obs in observations])) for name in observations[0]}


@pytest.mark.parametrize(
    ("network", "flatten_size", "feature_map"),
    [
        ("DEEP_CONVOLUTIONAL_NETWORK_SHALLOW", 11264, (11, 16, 64)),
        ("DEEP_CONVOLUTIONAL_NETWORK", 56000, (25, 35, 64)),
        ("DEEP_CONVOLUTIONAL_NETWORK_DEEP", 1152, (3, 6, 64)),
    ],
)
def test_camera_flatten_sizes_match_reference(network, flatten_size, feature_map):
    architecture = NETWORK_ARCHITECTURES[network]
    assert conv_output_shape(120, 160, architecture.camera_convs) == feature_map
    embedder = CameraEmbedder(FRONT, architecture.camera_convs, architecture.camera_dense)
    assert embedder.flatten_size == flatten_size
    # The real tensor agrees with the arithmetic (this is what would break with 'same' padding).
    conv_out = embedder.convs(torch.zeros(1, 1, 120, 160).to(memory_format=torch.channels_last))
    assert tuple(conv_out.shape[1:]) == (feature_map[2], feature_map[0], feature_map[1])


def test_layer_sizes_of_each_tower():
    shallow = build_actor_critic(metadata(["FRONT_FACING_CAMERA"]))
    convs = [m for m in shallow.policy_tower.modules() if isinstance(m, torch.nn.Conv2d)]
    assert [(c.in_channels, c.out_channels, c.kernel_size[0], c.stride[0], c.padding[0]) for c in convs] == [
        (1, 32, 8, 4, 0),
        (32, 64, 4, 2, 0),
        (64, 64, 3, 1, 0),
    ]
    dense = [m for m in shallow.policy_tower.modules() if isinstance(m, torch.nn.Linear)]
    assert [(d.in_features, d.out_features) for d in dense] == [(11264, 512)]
    assert shallow.policy_head.in_features == 512 and shallow.policy_head.out_features == 5

    deep = build_actor_critic(metadata(["FRONT_FACING_CAMERA"], "DEEP_CONVOLUTIONAL_NETWORK"))
    dense = [m for m in deep.value_tower.modules() if isinstance(m, torch.nn.Linear)]
    assert [(d.in_features, d.out_features) for d in dense] == [(56000, 64), (64, 512)]

    deepest = build_actor_critic(metadata(["FRONT_FACING_CAMERA"], "DEEP_CONVOLUTIONAL_NETWORK_DEEP"))
    dense = [m for m in deepest.policy_tower.modules() if isinstance(m, torch.nn.Linear)]
    assert [(d.in_features, d.out_features) for d in dense] == [(1152, 512), (512, 512), (512, 256), (256, 128)]
    assert deepest.value_head.in_features == 128


def test_every_conv_and_dense_layer_is_followed_by_relu():
    network = build_actor_critic(metadata(["FRONT_FACING_CAMERA", "LIDAR"], "DEEP_CONVOLUTIONAL_NETWORK_DEEP"))
    for tower in (network.policy_tower, network.value_tower):
        for sequence in [m for m in tower.modules() if isinstance(m, torch.nn.Sequential)]:
            layers = list(sequence)
            for index, layer in enumerate(layers):
                if isinstance(layer, torch.nn.Conv2d | torch.nn.Linear):
                    assert isinstance(layers[index + 1], torch.nn.ReLU)


def test_towers_are_independent_copies():
    network = build_actor_critic(metadata(["FRONT_FACING_CAMERA"]))
    policy_params = {id(p) for p in network.policy_tower.parameters()}
    assert policy_params.isdisjoint(id(p) for p in network.value_tower.parameters())
    # Different initial weights too (two separately initialised networks in DeepRacer's graph).
    first_policy = network.policy_tower.embedders["FRONT_FACING_CAMERA"].convs[0].weight
    first_value = network.value_tower.embedders["FRONT_FACING_CAMERA"].convs[0].weight
    assert not torch.equal(first_policy, first_value)


def test_stereo_and_lidar_inputs_concatenated_in_sorted_name_order(deepracer_data):
    md = load_model_metadata(
        deepracer_data / "config" / "dpr401_model_metadata_stereo_lidar_deep_two_speed_5steering.json"
    )
    config = policy_config_from_metadata(md)
    assert [spec.name for spec in config.inputs] == ["LIDAR", "STEREO_CAMERAS"]
    assert config.inputs[1].shape == (120, 160, 2) and config.inputs[0].shape == (64,)
    network = ActorCritic(config)
    stereo = network.policy_tower.embedders["STEREO_CAMERAS"]
    assert stereo.flatten_size == 25 * 35 * 128 and stereo.out_features == 25 * 35 * 128
    lidar = network.policy_tower.embedders["LIDAR"]
    assert lidar.out_features == 256
    first_middleware = network.policy_tower.middleware[0]
    assert first_middleware.in_features == 256 + 25 * 35 * 128 and first_middleware.out_features == 512

    # Sorted order means LIDAR features come first: zeroing the stereo columns of the first middleware layer
    # leaves the output depending on the lidar only.
    with torch.no_grad():
        first_middleware.weight[:, 256:] = 0
    rng = np.random.default_rng(0)
    obs = random_observation(config, rng)
    other = dict(obs, STEREO_CAMERAS=rng.integers(0, 256, size=(120, 160, 2), dtype=np.uint8))
    with torch.no_grad():
        a = network.distribution(batch_of([obs])).probs
        b = network.distribution(batch_of([other])).probs
    torch.testing.assert_close(a, b)


@pytest.mark.parametrize(
    ("sensors", "expected"),
    [
        (["SECTOR_LIDAR", "FRONT_FACING_CAMERA"], [("FRONT_FACING_CAMERA", (120, 160, 1)), ("SECTOR_LIDAR", (8,))]),
        (
            ["LEFT_CAMERA", "DISCRETIZED_SECTOR_LIDAR"],
            [("DISCRETIZED_SECTOR_LIDAR", (16,)), ("LEFT_CAMERA", (120, 160, 1))],
        ),
    ],
)
def test_input_shapes_from_metadata(sensors, expected):
    md = metadata(sensors, lidar_config={"num_sectors": 4, "num_values_per_sector": 4, "clipping_dist": 1.0})
    config = policy_config_from_metadata(md)
    assert [(spec.name, spec.shape) for spec in config.inputs] == expected
    network = ActorCritic(config)
    probs, log_prob = network.act(random_observation(config, np.random.default_rng(1)), greedy=True)
    assert 0 <= probs < 5 and log_prob <= 0.0


def test_images_are_divided_by_255_inside_the_network():
    network = build_actor_critic(metadata(["FRONT_FACING_CAMERA"]))
    rng = np.random.default_rng(2)
    raw = rng.integers(0, 256, size=(3, 120, 160, 1), dtype=np.uint8)
    embedder = network.policy_tower.embedders["FRONT_FACING_CAMERA"]
    with torch.no_grad():
        features = embedder(torch.from_numpy(raw))
        # Hand-rolled: scale, NCHW conv stack, flatten in Keras (H, W, C) order.
        x = torch.from_numpy(raw).float().permute(0, 3, 1, 2).contiguous() / 255.0
        for layer in embedder.convs:
            x = layer(x)
        expected = x.permute(0, 2, 3, 1).reshape(3, -1)
    torch.testing.assert_close(features, expected, rtol=1e-5, atol=1e-5)
    # Float input with the same raw 0-255 values gives the same result as uint8.
    with torch.no_grad():
        torch.testing.assert_close(embedder(torch.from_numpy(raw).float()), features)


def test_discrete_head_is_softmax_floored_at_1e8():
    network = build_actor_critic(metadata(["FRONT_FACING_CAMERA"]))
    with torch.no_grad():
        network.policy_head.bias.copy_(torch.tensor([40.0, 0.0, 0.0, 0.0, 0.0]))
        network.policy_head.weight.zero_()
        obs = {"FRONT_FACING_CAMERA": torch.zeros(2, 120, 160, 1, dtype=torch.uint8)}
        distribution = network.distribution(obs)
    assert isinstance(distribution, CategoricalPolicy)
    assert distribution.probs[0, 0].item() == pytest.approx(1.0)
    assert distribution.probs[0, 1].item() == pytest.approx(1e-8, rel=1e-6)  # softmax would give ~4e-18
    assert torch.allclose(distribution.log_prob(torch.tensor([1, 1])), torch.full((2,), math.log(1e-8)))


def test_continuous_head_mean_is_deepracers_linear_output_and_log_std_clipped():
    """DeepRacer's continuous head: the mean is the dense layer's output itself (RL Coach's tf.identity `policy`),
    not squashed; the environment clips to [-1, 1] when it scales the action. The log-std is clipped to [-20, 3]."""
    model_metadata = metadata(["FRONT_FACING_CAMERA"], action_space=CONTINUOUS)
    network = build_actor_critic(model_metadata)
    assert torch.equal(network.log_std.detach(), torch.zeros(2))
    with torch.no_grad():
        network.policy_head.bias.copy_(torch.tensor([50.0, -50.0]))
        network.log_std.copy_(torch.tensor([-100.0, 100.0]))
        distribution = network.distribution({"FRONT_FACING_CAMERA": torch.zeros(1, 120, 160, 1)})
    assert isinstance(distribution, GaussianPolicy)
    assert distribution.mean.tolist() == [[50.0, -50.0]]  # zero image: zero features, so the mean is the bias
    space = model_metadata.continuous_action_space
    assert model_metadata.scale_continuous_action(distribution.mean[0].tolist()) == (
        space.steering_angle_high_deg,
        space.speed_low_mps,
    )
    assert distribution.log_std.tolist() == [-20.0, 3.0]
    # Log-probability and entropy agree with torch's Normal.
    normal = torch.distributions.Normal(distribution.mean, distribution.log_std.exp())
    action = torch.tensor([[0.3, -0.2]])
    torch.testing.assert_close(distribution.log_prob(action), normal.log_prob(action).sum(-1))
    torch.testing.assert_close(distribution.entropy(), normal.entropy().sum(-1))


def test_continuous_initial_mean_is_near_zero_and_gradient_flows():
    network = build_actor_critic(metadata(["FRONT_FACING_CAMERA"], action_space=CONTINUOUS))
    obs = {"FRONT_FACING_CAMERA": torch.randint(0, 256, (4, 120, 160, 1), dtype=torch.uint8)}
    distribution = network.distribution(obs)
    assert distribution.mean.abs().max().item() < 0.2  # 0.01-scaled head init
    distribution.log_prob(torch.full((4, 2), 0.5)).sum().backward()
    assert network.policy_head.weight.grad.abs().sum() > 0 and network.log_std.grad.abs().sum() > 0


def test_kl_divergence_is_zero_for_identical_and_positive_for_different_policies():
    probs = torch.tensor([[0.7, 0.2, 0.1]])
    same = CategoricalPolicy(probs)
    other = CategoricalPolicy(torch.tensor([[0.1, 0.2, 0.7]]))
    assert same.kl_from(same).item() == pytest.approx(0.0, abs=1e-7)
    expected = 0.7 * math.log(7) + 0.1 * math.log(1 / 7)
    assert other.kl_from(same).item() == pytest.approx(expected, rel=1e-5)
    g_old = GaussianPolicy(torch.tensor([[0.0, 0.0]]), torch.tensor([0.0, 0.0]))
    g_new = GaussianPolicy(torch.tensor([[0.5, 0.0]]), torch.tensor([0.0, math.log(2.0)]))
    reference = torch.distributions.kl_divergence(
        torch.distributions.Normal(g_old.mean, g_old.log_std.exp()),
        torch.distributions.Normal(g_new.mean, g_new.log_std.exp()),
    ).sum(-1)
    torch.testing.assert_close(g_new.kl_from(g_old), reference)


def test_act_greedy_returns_argmax_and_its_log_prob():
    network = build_actor_critic(metadata(["FRONT_FACING_CAMERA"]))
    obs = random_observation(network.config, np.random.default_rng(3))
    with torch.no_grad():
        probs = network.distribution(batch_of([obs])).probs[0].numpy()
    action, log_prob = network.act(obs, greedy=True)
    assert action == int(probs.argmax()) and log_prob == pytest.approx(math.log(probs[action]), rel=1e-5)
    # Same generator state -> same sampled action: workers are reproducible.
    assert len({network.act(obs, False, np.random.default_rng(9))[0] for _ in range(3)}) == 1


def test_select_action_sampling_and_e_greedy_statistics():
    probs = np.array([0.1, 0.6, 0.05, 0.05, 0.2])
    distribution = CategoricalPolicy(torch.tensor(probs[None], dtype=torch.float32))
    rng = np.random.default_rng(4)
    counts = np.bincount([select_action(distribution, False, rng)[0] for _ in range(5000)], minlength=5)
    assert np.abs(counts / 5000 - probs).max() < 0.03  # sampling follows the policy's probabilities
    assert select_action(distribution, True, rng) == (1, pytest.approx(math.log(0.6)))

    rng = np.random.default_rng(5)
    picks = np.array([select_action(distribution, False, rng, epsilon=0.5)[0] for _ in range(5000)])
    assert np.mean(picks == 1) == pytest.approx(0.5 + 0.5 / 5, abs=0.03)  # argmax, plus its share of random picks
    assert np.mean(picks == 2) == pytest.approx(0.5 / 5, abs=0.03)  # other actions only through the random picks


def test_sample_categorical_draws_what_generator_choice_draws():
    """The rollout's sampler equals numpy's `choice(n, p=p)`: same action, same generator state after it, for float32
    softmax outputs floored at 1e-8 as the network gives them (so episodes stay what they were with `choice`)."""
    source = np.random.default_rng(11)
    for trial in range(300):
        logits = source.normal(0.0, 1.0 + 8.0 * (trial % 3), size=int(source.integers(2, 12)))
        probs = np.maximum(np.exp(logits - logits.max()) / np.exp(logits - logits.max()).sum(), 1e-8)
        p = probs.astype(np.float32).astype(np.float64)
        p = p / p.sum()
        ours, numpys = np.random.default_rng(trial), np.random.default_rng(trial)
        for _ in range(20):
            assert sample_categorical(p, ours) == int(numpys.choice(len(p), p=p))
        assert ours.random() == numpys.random()


def test_continuous_sampling_around_mean_with_std():
    distribution = GaussianPolicy(torch.tensor([[0.2, -0.4]]), torch.tensor([math.log(0.1), math.log(0.3)]))
    rng = np.random.default_rng(7)
    samples = np.stack([select_action(distribution, False, rng)[0] for _ in range(4000)])
    assert np.allclose(samples.mean(axis=0), [0.2, -0.4], atol=0.02)
    assert np.allclose(samples.std(axis=0), [0.1, 0.3], atol=0.02)
    action, log_prob = select_action(distribution, False, np.random.default_rng(8))
    expected = distribution.log_prob(torch.from_numpy(action)[None])
    assert log_prob == pytest.approx(expected.item(), abs=1e-4)
    mean, _ = select_action(distribution, True)
    assert mean.dtype == np.float32 and mean.tolist() == pytest.approx([0.2, -0.4])
    with pytest.raises(ValueError, match="e-greedy"):
        select_action(distribution, False, epsilon=0.1)


def test_act_continuous_through_the_network():
    network = build_actor_critic(metadata(["FRONT_FACING_CAMERA"], action_space=CONTINUOUS))
    obs = random_observation(network.config, np.random.default_rng(6))
    mean, _ = network.act(obs, greedy=True)
    with torch.no_grad():
        expected = network.distribution(batch_of([obs])).mean[0].numpy()
    assert mean.shape == (2,) and np.allclose(mean, expected, atol=1e-6)
    action, log_prob = network.act(obs, greedy=False, generator=np.random.default_rng(8))
    assert not np.allclose(action, mean) and np.isfinite(log_prob)


def test_act_rejects_wrong_observations():
    network = build_actor_critic(metadata(["FRONT_FACING_CAMERA"]))
    with pytest.raises(KeyError, match="FRONT_FACING_CAMERA"):
        network.act({"LIDAR": np.zeros(64, np.float32)}, greedy=True)
    with pytest.raises(ValueError, match=r"\(120, 160, 1\)"):
        network.act({"FRONT_FACING_CAMERA": np.zeros((120, 160, 3), np.uint8)}, greedy=True)


def test_e_greedy_schedule_is_linear_from_one():
    assert e_greedy_epsilon(0, 0.05, 10000) == 1.0
    assert e_greedy_epsilon(5000, 0.05, 10000) == pytest.approx(0.525)
    assert e_greedy_epsilon(10000, 0.05, 10000) == pytest.approx(0.05)
    assert e_greedy_epsilon(50000, 0.05, 10000) == pytest.approx(0.05)


def test_policy_config_round_trips_and_validates():
    config = policy_config_from_metadata(metadata(["LIDAR", "FRONT_FACING_CAMERA"]))
    assert PolicyConfig.from_dict(config.to_dict()) == config
    with pytest.raises(ValueError, match="sorted"):
        PolicyConfig("DEEP_CONVOLUTIONAL_NETWORK", (InputSpec("LIDAR", "vector", (64,)), FRONT), "discrete", 3)
    with pytest.raises(ValueError, match="neural_network"):
        PolicyConfig("RESNET", (FRONT,), "discrete", 3)


def test_in_training_evaluation_keeps_rl_coachs_evaluation_epsilon_under_e_greedy(deepracer_data):
    """RL Coach's EGreedy uses `evaluation_epsilon` (0.05) in the TEST phase; DeepRacer's in-training evaluations run
    in that phase, so under `e-greedy` they still take 5 % random actions. Categorical exploration stays argmax."""
    import json

    from racer.rollout_worker.checkpoint_evaluation import evaluation_epsilon
    from racer.shared.deepracer.hyperparameters import parse_hyperparameters

    raw = json.loads((deepracer_data / "config" / "console2022_ip_hyperparameters.json").read_text())
    discrete = load_model_metadata(deepracer_data / "config" / "console2022_model_metadata.json")
    continuous = load_model_metadata(deepracer_data / "config" / "drfc_defaults_model_metadata_cont.json")
    categorical, _ = parse_hyperparameters(raw)
    e_greedy, _ = parse_hyperparameters({**raw, "exploration_type": "e-greedy"})
    assert evaluation_epsilon(categorical, discrete) == 0.0
    assert evaluation_epsilon(e_greedy, continuous) == 0.0
    epsilon = evaluation_epsilon(e_greedy, discrete)
    assert epsilon == E_GREEDY_EVALUATION_EPSILON == 0.05

    distribution = CategoricalPolicy(torch.tensor([[0.1, 0.6, 0.05, 0.05, 0.2]], dtype=torch.float32))
    rng = np.random.default_rng(6)
    picks = np.array([select_action(distribution, True, rng, epsilon=epsilon)[0] for _ in range(8000)])
    assert np.mean(picks != 1) == pytest.approx(epsilon * 4 / 5, abs=0.01)
