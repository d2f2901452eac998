"""RACER_EVAL_MAX_STEPS (workers.json): worker 0's in-training evaluation episodes end after that many steps, as
DeepRacer's own 100,000-step cap ends one (truncated, the episode's last row done); unset (0, the default) they run
to the end, and training episodes never have the cap."""

from __future__ import annotations

import threading

import numpy as np
import pytest

from racer.rollout_worker.checkpoint_evaluation import evaluate_checkpoint
from racer.rollout_worker.worker_files import WorkerFiles
from racer.shared.deepracer.episode_status import EpisodeStatus
from racer.shared.deepracer.hyperparameters import Hyperparameters
from racer.shared.deepracer.metrics import TrainingMetricsEntry
from racer.shared.deepracer.model_metadata import parse_model_metadata
from racer.shared.episode_loop import play_episode
from racer.shared.model_layout import ModelLayout
from racer.shared.sim.env import DeepRacerEnv, EnvConfig
from racer.shared.worker_settings import WorkerSettings

METADATA = parse_model_metadata(
    {
        "action_space": [{"steering_angle": angle, "speed": 1.0} for angle in (-30, 0, 30)],
        "sensor": ["FRONT_FACING_CAMERA"],
        "neural_network": "DEEP_CONVOLUTIONAL_NETWORK_SHALLOW",
        "version": "5",
    },
    "three actions",
)
CAP = 6


class Straight:
    """A greedy policy that always steers 0°: on the oval it drives on for many steps, then leaves the track."""

    def act(self, observation, *, greedy, generator, epsilon=0.0):
        return 1, 0.0


@pytest.fixture
def env():
    env = DeepRacerEnv(EnvConfig(track="racer_oval", model_metadata=METADATA), wall_clock=lambda: 1700000000.0)
    yield env
    env.close()


def evaluate(env: DeepRacerEnv, settings: WorkerSettings) -> list:
    run = WorkerFiles(ModelLayout("m"), METADATA, Hyperparameters(), env.config.reward_function_path, settings)
    return evaluate_checkpoint(
        env, Straight(), run, 3, 0, np.random.default_rng(0), lambda *step: None, threading.Event()
    )


def test_evaluation_trials_end_at_the_cap_and_run_on_without_it(env):
    capped = evaluate(env, WorkerSettings(min_eval_trials=2, eval_max_steps=CAP))
    assert [played.steps for played in capped] == [CAP, CAP]
    for played in capped:
        assert played.final_status == "in_progress" and played.simtrace_rows[-1]["done"]
    uncapped = evaluate(env, WorkerSettings(min_eval_trials=1))
    assert uncapped[0].steps > 3 * CAP and uncapped[0].final_status == "off_track"
    assert [row["episode"] for row in uncapped[0].simtrace_rows[:1]] == [2]  # the capped trials were counted


def test_a_training_episode_has_no_cap(env):
    played = play_episode(
        env, Straight(), greedy=False, generator=np.random.default_rng(0), policy_version=0, worker_id=0,
        world="base", episode_index=0,
    )  # fmt: skip
    assert played.steps > 3 * CAP and played.final_status == "off_track"


def test_the_reset_option_is_checked_and_never_exceeds_the_envs_own_cap():
    env = DeepRacerEnv(EnvConfig(model_metadata=METADATA, max_steps=4), wall_clock=lambda: 1700000000.0)
    try:
        env.reset(options={"evaluation": True, "max_steps": 50})
        ended = [env.step(1)[3] for _ in range(4)]
        assert ended == [False, False, False, True]
        for wrong in (0, -3, 2.5, True):
            with pytest.raises(ValueError, match="'max_steps' must be a whole number >= 1"):
                env.reset(options={"max_steps": wrong})
    finally:
        env.close()


def test_the_setting_defaults_to_no_cap_and_refuses_a_negative_one():
    assert WorkerSettings().eval_max_steps == 0
    assert WorkerSettings.from_training_params({"RACER_EVAL_MAX_STEPS": "300"}, "workers.json").eval_max_steps == 300
    with pytest.raises(ValueError, match="RACER_EVAL_MAX_STEPS must be >= 0"):
        WorkerSettings(eval_max_steps=-1)


# A U-turn on re:Invent 2019 (wide enough to turn on at 0.3 m/s), then straight on at 2 m/s: the car drives back past
# its start line. The SimApp does not clamp progress there (deepracer-simapp v6.0.5 116686f4
# `bundle/markov/agent_ctrl/utils.py` compute_current_prog caps at 100 only) and writes
# `completion_percentage = int(last step's progress)` (`bundle/markov/metrics/s3_metrics.py`
# TrainingMetrics.append_episode_metrics), so an episode that ends behind the line records a negative percentage.
U_TURN_METADATA = parse_model_metadata(
    {
        "action_space": [{"steering_angle": -30, "speed": 0.3}, {"steering_angle": 0, "speed": 2.0}],
        "sensor": ["FRONT_FACING_CAMERA"],
        "neural_network": "DEEP_CONVOLUTIONAL_NETWORK_SHALLOW",
        "version": "5",
    },
    "u-turn actions",
)
U_TURN_STEPS = 52


class UTurnThenStraight:
    """Turns left for U_TURN_STEPS steps, then drives straight: back along the track, behind the start line."""

    def __init__(self):
        self.calls = 0

    def act(self, observation, *, greedy, generator, epsilon=0.0):
        self.calls += 1
        return (0 if self.calls <= U_TURN_STEPS else 1), 0.0


def evaluate_u_turn(env: DeepRacerEnv, eval_max_steps: int):
    run = WorkerFiles(
        ModelLayout("m"), U_TURN_METADATA, Hyperparameters(), env.config.reward_function_path,
        WorkerSettings(min_eval_trials=1, eval_max_steps=eval_max_steps),
    )  # fmt: skip
    (played,) = evaluate_checkpoint(
        env, UTurnThenStraight(), run, 3, 0, np.random.default_rng(0), lambda *step: None, threading.Event()
    )
    return played


def metrics_entry(played) -> TrainingMetricsEntry:
    return TrainingMetricsEntry.from_episode(
        total_reward=played.total_reward, start_time_s=played.start_time_s, end_time_s=played.end_time_s,
        episode=1, trial=1, phase="evaluation", progress_pct=played.progress, status=EpisodeStatus(played.final_status),
    )  # fmt: skip


def test_an_evaluation_capped_behind_the_start_line_records_negative_progress_as_the_simapp(deepracer_data):
    env = DeepRacerEnv(
        EnvConfig(track="reInvent2019_track", model_metadata=U_TURN_METADATA), wall_clock=lambda: 1700000000.0
    )
    try:
        uncapped = evaluate_u_turn(env, 0)
        # Not the cap's doing: run to its end, the episode already ends behind the line and records that.
        assert uncapped.final_status in ("off_track", "reversed") and uncapped.progress < -1.0
        assert metrics_entry(uncapped).completion_percentage == int(uncapped.progress) < 0
        # The cap stops the same (deterministic) episode at its last in-progress row, the car behind the line.
        cap = len(uncapped.simtrace_rows) - 1
        last_running = uncapped.simtrace_rows[cap - 1]
        assert last_running["episode_status"] == "in_progress" and last_running["progress"] < -1.0
        capped = evaluate_u_turn(env, cap)
        assert capped.steps == cap and capped.final_status == "in_progress"
        assert capped.progress == pytest.approx(last_running["progress"])
        entry = metrics_entry(capped).to_dict()
        # int() truncates toward zero, as the SimApp's does: -6.6 % is recorded as -6, -0.9 % as 0.
        assert entry["completion_percentage"] == int(capped.progress) < 0
        assert entry["episode_status"] == "In progress"
    finally:
        env.close()
