"""Training presets (preset.json): parsing and refusal naming the keys, a preset of DeepRacer's defaults reproduces
the PPO update without a preset bit for bit, the parameters change the update, SAC's target copy rate, and the
learner factory and preflight carry the preset."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest
import torch

from racer.shared.deepracer.hyperparameters import Hyperparameters
from racer.shared.run_settings import RunOptions
from racer.shared.user_errors import RunConfigError
from racer.trainer.ppo import PPOLearner, PPOSettings
from racer.trainer.preflight import preflight
from racer.trainer.preset import Preset, PresetError, load_preset, parse_preset
from racer.trainer.sac import SACSettings
from tests.trainer.ppo_task import random_episodes, task_network
from tests.trainer.test_preflight import DEFAULT_HYPERPARAMETERS, DEFAULT_METADATA, custom_files_from

HP = Hyperparameters(batch_size=32, num_epochs=2, lr=3e-4, beta_entropy=0.01, discount_factor=0.99, loss_type="huber")
DEFAULTS_SPELLED_OUT = {
    "clip_likelihood_ratio_using_epsilon": 0.2,
    "gae_lambda": 0.95,
    "value_loss_weight": 1,
    "optimizer_epsilon": 1e-5,
    "adam_optimizer_beta1": 0.9,
    "adam_optimizer_beta2": 0.999,
    "clip_gradients": None,
    "kl_cutoff": None,
    "desired_kl": None,
    "anneal_lr": False,
    "clipping_decay_schedule": {"type": "constant", "value": 1},
}


def weights_after_one_update(settings: PPOSettings, hyperparameters: Hyperparameters = HP) -> dict[str, torch.Tensor]:
    network = task_network(3, seed=0)
    episodes = random_episodes(network, [30, 25, 20], np.random.default_rng(0))
    PPOLearner(network, hyperparameters, settings).update(episodes)
    return {name: value.detach().clone() for name, value in network.state_dict().items()}


def test_a_preset_of_deepracers_defaults_reproduces_the_update_without_a_preset():
    preset = parse_preset(DEFAULTS_SPELLED_OUT, "clipped_ppo")
    assert preset == Preset()
    plain = weights_after_one_update(PPOSettings(seed=0))
    with_preset = weights_after_one_update(preset.ppo_settings(PPOSettings(seed=0)))
    for name, tensor in plain.items():
        assert torch.equal(tensor, with_preset[name]), name


def test_the_preset_parameters_change_the_update():
    plain = weights_after_one_update(PPOSettings(seed=0))
    for change in ({"value_loss_weight": 0.5}, {"clip_gradients": 0.01}, {"gae_lambda": 0.5}):
        changed = weights_after_one_update(parse_preset(change, "clipped_ppo").ppo_settings(PPOSettings(seed=0)))
        assert any(not torch.equal(plain[name], changed[name]) for name in plain), change


def test_the_kl_cutoff_stops_the_remaining_epochs():
    network = task_network(3, seed=0)
    episodes = random_episodes(network, [30, 25, 20], np.random.default_rng(0))
    settings = parse_preset({"kl_cutoff": 1e-12}, "clipped_ppo").ppo_settings(PPOSettings(seed=0))
    stats = PPOLearner(network, replace(HP, num_epochs=5), settings).update(episodes)
    assert len(stats) < 5


def test_desired_kl_moves_the_learning_rate_towards_the_kl_it_asks_for():
    """A target far below what an update's steps give lowers the rate; one far above raises it; both start at lr."""
    rates = {}
    for desired_kl in (1e-9, 1e3):
        network = task_network(3, seed=0)
        episodes = random_episodes(network, [30, 25, 20], np.random.default_rng(0))
        settings = parse_preset({"desired_kl": desired_kl}, "clipped_ppo").ppo_settings(PPOSettings(seed=0))
        learner = PPOLearner(network, HP, settings)
        learner.update(episodes)
        rates[desired_kl] = learner.learning_rate
    assert rates[1e-9] < HP.lr < rates[1e3]


@pytest.mark.parametrize(
    ("data", "message"),
    [
        ({"clip_range": 0.1, "entropy": 1}, r"clip_range, entropy: unknown preset key\(s\); allowed: clip_likelihood"),
        ({"beta_entropy": 0.1}, r"beta_entropy: a hyperparameters.json key; fix: set it there"),
        (
            {"rate_for_copying_weights_to_target": 0.5},
            r"rate_for_copying_weights_to_target: not a clipped_ppo parameter",
        ),
        ({"gae_lambda": 1.5}, r"gae_lambda: 1.5 is outside \[0.0, 1.0\]"),
        ({"clip_likelihood_ratio_using_epsilon": 0}, r"clip_likelihood_ratio_using_epsilon: 0 is outside \(0.0"),
        ({"optimizer_epsilon": "small"}, r"optimizer_epsilon: 'small' is not a number"),
        ({"gae_lambda": None}, r"gae_lambda: None is not a number"),
        ({"updates_per_transition": 0.5}, r"updates_per_transition: not a clipped_ppo parameter"),
        ({"anneal_lr": 1}, r"anneal_lr: 1 is not true or false"),
        ({"anneal_lr": True, "desired_kl": 0.01}, r"anneal_lr and desired_kl: both move the learning rate"),
        ({"clipping_decay_schedule": {"type": "cosine"}}, r"clipping_decay_schedule: type: 'cosine' is not one of"),
        ({"clipping_decay_schedule": 1}, r"clipping_decay_schedule: expected an object with a type"),
        (
            {"clipping_decay_schedule": {"type": "linear", "initial_value": 1, "final_value": 0.1}},
            r"clipping_decay_schedule: decay_steps: missing; a linear schedule takes type, initial_value",
        ),
        (
            {"clipping_decay_schedule": {"type": "constant", "value": 1, "final_value": 1}},
            r"clipping_decay_schedule: final_value: unknown field\(s\); a constant schedule takes type, value",
        ),
        (
            {"clipping_decay_schedule": {"type": "linear", "initial_value": 1, "final_value": 0.1, "decay_steps": 0}},
            r"clipping_decay_schedule: decay_steps: 0 is not a positive whole number",
        ),
        (
            {"clipping_decay_schedule": {"type": "linear", "initial_value": 1, "final_value": 0.1, "decay_steps": 2.5}},
            r"clipping_decay_schedule: decay_steps: 2.5 is not a positive whole number",
        ),
        (
            {"clipping_decay_schedule": {"type": "linear", "initial_value": 1, "final_value": 0, "decay_steps": 9}},
            r"clipping_decay_schedule: final_value: 0 is outside \(0, 5\]",
        ),
        (  # the clip range 0.5 x 3 would pass 1
            {"clip_likelihood_ratio_using_epsilon": 0.5, "clipping_decay_schedule": {"type": "constant", "value": 3}},
            r"clipping_decay_schedule: value: 3 is outside \(0, 2\]: the clip range, clip_likelihood_ratio_using_epsilon \(0.5\)",
        ),
        (
            {"clipping_decay_schedule": {"type": "constant", "value": "one"}},
            r"clipping_decay_schedule: value: 'one' is not a number",
        ),
        ([], r"expected a JSON object"),
    ],
)
def test_a_bad_preset_is_refused_naming_the_keys(data, message):
    with pytest.raises(PresetError, match=rf"^preset.json: {message}"):
        parse_preset(data, "clipped_ppo")


def test_sac_presets_set_the_target_copy_rate():
    with pytest.raises(PresetError, match="gae_lambda: not a sac parameter"):
        parse_preset({"gae_lambda": 0.9}, "sac")
    with pytest.raises(PresetError, match="clipping_decay_schedule: not a sac parameter"):
        parse_preset({"clipping_decay_schedule": {"type": "constant", "value": 1}}, "sac")
    preset = parse_preset({"rate_for_copying_weights_to_target": 0.005}, "sac")
    assert preset.sac_settings(SACSettings()).target_copy_rate == 0.005
    assert Preset().sac_settings(SACSettings()) == SACSettings()


def test_sac_soft_target_update_moves_the_target_part_of_the_way():
    from racer.shared.deepracer.model_metadata import parse_model_metadata
    from racer.shared.policy.factory import build_network_for_metadata

    space = {"steering_angle": {"low": -30, "high": 30}, "speed": {"low": 0.5, "high": 2.0}}
    data = {"action_space": space, "action_space_type": "continuous", "sensor": ["FRONT_FACING_CAMERA"], "version": "5"}
    networks = build_network_for_metadata(parse_model_metadata({**data, "training_algorithm": "sac"}))
    with torch.no_grad():
        for parameter in networks.value_head.parameters():
            parameter.add_(1.0)
    before = networks.target_value_head.weight.detach().clone()
    networks.sync_target(0.25)
    expected = before + 0.25 * (networks.value_head.weight.detach() - before)
    assert torch.allclose(networks.target_value_head.weight, expected)
    networks.sync_target()
    assert torch.equal(networks.target_value_head.weight, networks.value_head.weight)


def test_preflight_reads_the_preset_and_refuses_a_bad_one(tmp_path):
    folder = custom_files_from(tmp_path, DEFAULT_METADATA, DEFAULT_HYPERPARAMETERS)
    assert (
        preflight(folder, RunOptions(1, "racer_oval", ("base",))).preset is None
        and load_preset(folder, "clipped_ppo") is None
    )
    (folder / "preset.json").write_text(json.dumps({"clip_likelihood_ratio_using_epsilon": 0.1}))
    report = preflight(folder, RunOptions(1, "racer_oval", ("base",)))
    assert report.preset == Preset(clip_likelihood_ratio_using_epsilon=0.1)
    (folder / "preset.json").write_text(json.dumps({"clip_range": 0.1}))
    with pytest.raises(RunConfigError, match=rf"^{folder / 'preset.json'}: clip_range: unknown preset key"):
        preflight(folder, RunOptions(1, "racer_oval", ("base",)))
