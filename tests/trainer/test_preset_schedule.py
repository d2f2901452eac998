"""The two preset keys that move the update over a run: PPO's `clipping_decay_schedule` (the clip range the loss
uses follows the run's environment steps) and SAC's `updates_per_transition` (gradient steps per transition, which
a different `--sac-updates-per-transition` may not silently override); both default to the update without a
preset, exactly."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest
import torch
from click.testing import CliRunner

from racer.shared.deepracer.hyperparameters import Hyperparameters
from racer.shared.deepracer.model_metadata import parse_model_metadata
from racer.shared.policy.sac_networks import SACNetworks
from racer.trainer.algorithms import LearnerOptions, build_learner
from racer.trainer.cli import trainer_command
from racer.trainer.clip_schedule import ClipSchedule
from racer.trainer.ppo import CLIP_EPSILON, PPOLearner, PPOSettings
from racer.trainer.preset import Preset, PresetError, parse_preset, sac_updates_per_transition
from racer.trainer.sac import SACLearner, SACSettings
from tests.trainer.ppo_task import random_episodes, task_network
from tests.trainer.test_preflight import custom_files_from
from tests.trainer.test_preset import HP, weights_after_one_update
from tests.trainer.test_sac import LIDAR_ONLY, SAC_METADATA, bandit_episodes

LINEAR = {"type": "linear", "initial_value": 1.0, "final_value": 0.25, "decay_steps": 1000}
SAC_HP = Hyperparameters(batch_size=16, lr=3e-4, sac_alpha=0.2)


def ppo_trainer(schedule: dict | None) -> tuple[PPOLearner, list]:
    data = {} if schedule is None else {"clipping_decay_schedule": schedule}
    network = task_network(3, seed=0)
    episodes = random_episodes(network, [30, 25, 20], np.random.default_rng(0))
    settings = parse_preset(data, "clipped_ppo").ppo_settings(PPOSettings(seed=0))
    return PPOLearner(network, HP, settings), episodes


def test_the_linear_schedule_moves_the_clip_range_by_environment_steps():
    schedule = ClipSchedule("linear", 1.0, 0.25, 1000)
    assert [schedule.value_at(steps) for steps in (0, 500, 1000, 10**9)] == [1.0, 0.625, 0.25, 0.25]
    rising = ClipSchedule("linear", 0.5, 1.0, 10)
    assert [rising.value_at(steps) for steps in (0, 5, 20)] == [0.5, 0.75, 1.0]
    assert ClipSchedule().value_at(10**9) == 1.0


def test_the_clip_range_the_loss_uses_follows_the_schedule():
    trainer, episodes = ppo_trainer(LINEAR)
    first = trainer.update(episodes, env_steps=75)
    assert {epoch.clip_range for epoch in first} == {CLIP_EPSILON * (1 - 0.75 * 75 / 1000)}
    late = trainer.update(episodes, env_steps=5000)
    assert {epoch.clip_range for epoch in late} == {CLIP_EPSILON * 0.25} and trainer.clip_range == CLIP_EPSILON * 0.25
    # Without the trainer's count the learner counts what it was given: 75 transitions per update.
    counting, _ = ppo_trainer(LINEAR)
    assert [counting.update(episodes)[0].clip_range for _ in range(2)] == [
        CLIP_EPSILON * (1 - 0.75 * 75 / 1000),
        CLIP_EPSILON * (1 - 0.75 * 150 / 1000),
    ]


def test_the_schedules_clip_range_is_the_one_the_surrogate_clips_with():
    """An update at a step where the schedule says 0.25 is, bit for bit, the update with a clip range of 0.05."""
    trainer, episodes = ppo_trainer(LINEAR)
    trainer.update(episodes, env_steps=1000)
    scheduled = {name: value.detach().clone() for name, value in trainer.network.state_dict().items()}
    narrow = weights_after_one_update(PPOSettings(seed=0, clip_epsilon=CLIP_EPSILON * 0.25))
    plain = weights_after_one_update(PPOSettings(seed=0))
    for name, tensor in narrow.items():
        assert torch.equal(tensor, scheduled[name]), name
    assert any(not torch.equal(plain[name], scheduled[name]) for name in plain)


@pytest.mark.parametrize("schedule", [None, {"type": "constant", "value": 1}, {"type": "constant", "value": 1.0}])
def test_the_default_schedule_is_the_unscheduled_update_at_any_step(schedule):
    plain = weights_after_one_update(PPOSettings(seed=0))
    trainer, episodes = ppo_trainer(schedule)
    stats = trainer.update(episodes, env_steps=10**7)
    assert {epoch.clip_range for epoch in stats} == {CLIP_EPSILON}
    for name, tensor in plain.items():
        assert torch.equal(tensor, trainer.network.state_dict()[name]), name


def test_the_schedule_is_stored_in_the_preset_spelling():
    preset = parse_preset({"clipping_decay_schedule": {**LINEAR, "decay_steps": 1e3}}, "clipped_ppo")
    assert preset.to_dict()["clipping_decay_schedule"] == LINEAR
    assert json.loads(json.dumps(Preset().to_dict()))["clipping_decay_schedule"] == {"type": "constant", "value": 1.0}


def sac_weights_after_one_update(settings: SACSettings) -> tuple[dict[str, torch.Tensor], int]:
    torch.manual_seed(0)
    networks = SACNetworks(LIDAR_ONLY)
    episodes = bandit_episodes(networks, 40, np.random.default_rng(0))
    (stats,) = SACLearner(networks, SAC_HP, settings).update(episodes)
    return {name: value.detach().clone() for name, value in networks.state_dict().items()}, stats.gradient_steps


def test_a_sac_preset_of_deepracers_defaults_reproduces_the_update_without_a_preset():
    base = SACSettings(replay_memory_bytes=8 << 20, seed=0)
    preset = parse_preset({"rate_for_copying_weights_to_target": 1, "updates_per_transition": 1}, "sac")
    settings = preset.sac_settings(replace(base, updates_per_transition=sac_updates_per_transition(None, preset)))
    assert settings == base
    plain, plain_steps = sac_weights_after_one_update(base)
    with_preset, steps = sac_weights_after_one_update(settings)
    assert steps == plain_steps == 40
    for name, tensor in plain.items():
        assert torch.equal(tensor, with_preset[name]), name


def sac_learner(options: LearnerOptions) -> SACLearner:
    metadata = parse_model_metadata(SAC_METADATA)
    learner = build_learner(metadata, SAC_HP, options)
    assert isinstance(learner, SACLearner)
    return learner


def test_the_sac_ratio_sets_the_number_of_gradient_steps():
    preset = parse_preset({"updates_per_transition": 0.25}, "sac")
    _, steps = sac_weights_after_one_update(preset.sac_settings(SACSettings(replay_memory_bytes=8 << 20, seed=0)))
    assert steps == 10  # 40 transitions x 0.25
    options = LearnerOptions(seed=0, sac_replay_memory_mb=16, preset=preset)
    assert sac_learner(options).settings.updates_per_transition == 0.25


def test_the_command_line_ratio_and_the_presets_may_not_disagree():
    preset = Preset(updates_per_transition=0.25)
    assert sac_updates_per_transition(None, None) == 1.0  # DeepRacer's
    assert sac_updates_per_transition(0.5, None) == 0.5
    assert sac_updates_per_transition(None, preset) == 0.25
    assert sac_updates_per_transition(0.25, preset) == 0.25  # the same value twice ignores neither
    with pytest.raises(
        PresetError, match=r"^preset.json: updates_per_transition: 0.25 conflicts with --sac-updates-per-transition 0.5"
    ):
        sac_learner(LearnerOptions(seed=0, sac_replay_memory_mb=16, sac_updates_per_transition=0.5, preset=preset))


def test_racer_trainer_refuses_the_conflict_before_anything_connects(tmp_path):
    folder = custom_files_from(tmp_path, "drfc_defaults_model_metadata_sac.json", "dots_hyperparameters_sac.json")
    (folder / "preset.json").write_text(json.dumps({"updates_per_transition": 0.25}))
    arguments = ["--model-prefix", "m", "--custom-files", str(folder), "--workers", "1", "--track", "racer_oval"]
    result = CliRunner().invoke(trainer_command, [*arguments, "--worlds", "base", "--sac-updates-per-transition", "2"])
    assert result.exit_code != 0
    assert f"{folder / 'preset.json'}: updates_per_transition: 0.25 conflicts with --sac-updates-per-transition 2" in (
        result.output
    )


def test_the_trainer_clocks_the_schedule_with_its_resumable_step_count(redis_settings, tmp_path):
    from racer.shared.redis_connection import RedisLink
    from racer.shared.transport.channels import RunChannel
    from tests.conftest import write_custom_files
    from tests.trainer.test_training_loop import PREFIX, make_trainer, wire_episode

    custom = write_custom_files(tmp_path / "custom_files", steering_deg=(-30, -15, 0, 15, 30), min_eval_trials=None)
    trainer = make_trainer(redis_settings, tmp_path, custom)
    assert trainer.setup() == 0
    trainer.env_steps = 1000  # as a checkpoint restores it
    channel = RunChannel(RedisLink(redis_settings), PREFIX)
    for number in (0, 1):
        channel.push_episode(wire_episode(iteration=0, number=number, worker_id=number, policy_version=0, seed=number))
    trainer.train_iteration(0, trainer.collect(0), rollout_wall_s=0.0)
    assert trainer.env_steps == 1040 and trainer.learner.env_steps == 1040  # two episodes of 20 steps
