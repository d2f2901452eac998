"""RACER_EVAL_CONTINUOUS (workers.json): worker 0's in-training evaluation drives its MIN_EVAL_TRIALS laps in one run,
each crossing of the line closing a lap and the next going on at speed, as DeepRacer's continuous evaluation; the
first reset rule ends the run. Without it, every trial starts from rest at the line, and in racer's deterministic
simulator those trials are one lap driven again."""

from __future__ import annotations

import math
import threading

import numpy as np
import pytest

from racer.rollout_worker.checkpoint_evaluation import evaluate_checkpoint
from racer.rollout_worker.worker_files import WorkerFiles
from racer.shared.deepracer.hyperparameters import Hyperparameters
from racer.shared.deepracer.model_metadata import parse_model_metadata
from racer.shared.episode_loop import play_episode
from racer.shared.model_layout import ModelLayout
from racer.shared.sim.env import DeepRacerEnv, EnvConfig
from racer.shared.worker_settings import WorkerSettings

METADATA = parse_model_metadata(
    {
        "action_space": {"steering_angle": {"low": -30.0, "high": 30.0}, "speed": {"low": 0.5, "high": 3.0}},
        "action_space_type": "continuous",
        "sensor": ["FRONT_FACING_CAMERA"],
        "neural_network": "DEEP_CONVOLUTIONAL_NETWORK_SHALLOW",
        "version": "5",
    },
    "continuous test space",
)


class Follower:
    """A greedy stand-in that steers for the centre line 0.6 m ahead at 2 m/s (pure pursuit on the env's own
    geometry); `off_at_progress` turns it off the road once past that progress of its second lap."""

    def __init__(self, env: DeepRacerEnv, off_at_progress: float | None = None):
        self.env = env.unwrapped
        self.off_at_progress = off_at_progress
        self.crossings = 0
        self._last_ndist = 0.0

    def act(self, observation, *, greedy, generator, epsilon=0.0):
        assert greedy
        core = self.env
        pose = core.car.pose(core.data)
        track = core.track
        ndist = track.project_normalized(*pose.model_point)
        if ndist < self._last_ndist - 0.5:
            self.crossings += 1
        self._last_ndist = ndist
        tx, ty, yaw = track.pose_at((ndist + 0.6 / track.length_m) % 1.0, "center")
        if self.off_at_progress is not None and self.crossings >= 1 and 100 * ndist > self.off_at_progress:
            tx, ty = tx + 3.0 * math.sin(yaw), ty - 3.0 * math.cos(yaw)
        error = math.atan2(ty - pose.origin_y_m, tx - pose.origin_x_m) - pose.yaw_rad
        steering_deg = max(-30.0, min(30.0, math.degrees((error + math.pi) % (2 * math.pi) - math.pi) * 1.5))
        return np.array([steering_deg / 30.0, (2.0 - 1.75) / 1.25], dtype=np.float32), 0.0


class Straight:
    """Full speed ahead, no steering: off the oval within a few metres."""

    def act(self, observation, *, greedy, generator, epsilon=0.0):
        return np.array([0.0, 1.0], dtype=np.float32), 0.0


@pytest.fixture
def env():
    env = DeepRacerEnv(EnvConfig(track="racer_oval", model_metadata=METADATA), wall_clock=lambda: 1700000000.0)
    yield env
    env.close()


def evaluate(env: DeepRacerEnv, policy, settings: WorkerSettings) -> list:
    run = WorkerFiles(ModelLayout("m"), METADATA, Hyperparameters(), env.config.reward_function_path, settings)
    return evaluate_checkpoint(env, policy, run, 3, 0, np.random.default_rng(0), lambda *step: None, threading.Event())


def test_continuous_laps_run_on_from_one_crossing_to_the_next(env):
    laps = evaluate(env, Follower(env), WorkerSettings(min_eval_trials=3, eval_continuous=True))
    assert [lap.final_status for lap in laps] == ["lap_complete"] * 3
    assert laps[0].simtrace_rows[0]["episode_status"] == "prepare"  # only the run's first step stands still
    for before, after in zip(laps, laps[1:], strict=False):
        assert after.start_time_s == before.end_time_s  # the next lap's clock starts at the crossing
        first = after.simtrace_rows[0]
        assert first["episode_status"] == "in_progress" and first["progress"] < 5.0  # on at speed, progress anew
        moved_m = math.dist((first["X"], first["Y"]), (before.simtrace_rows[-1]["X"], before.simtrace_rows[-1]["Y"]))
        assert 0.0 < moved_m < 0.3  # one step on from the crossing (2 m/s for 1/15 s)
    times = [lap.lap_time_s for lap in laps]
    assert times == pytest.approx([lap.end_time_s - lap.start_time_s for lap in laps])
    separate = evaluate(env, Follower(env), WorkerSettings(min_eval_trials=3))
    assert [lap.lap_time_s for lap in separate] == pytest.approx([times[0]] * 3, abs=1e-6)  # the first lap again
    # A lap that starts at speed, from where the last one left the car, is another lap.
    assert times[1] != pytest.approx(times[0], abs=1e-6)
    for _ in range(3):  # training episodes move the round-robin start on; the evaluation still starts at the line
        play_episode(env, Straight(), greedy=False, generator=np.random.default_rng(0), policy_version=0,
                     worker_id=0, world="base", episode_index=0)  # fmt: skip
    assert env.start_ndist > 0.1
    again = evaluate(env, Follower(env), WorkerSettings(min_eval_trials=3, eval_continuous=True))
    assert [lap.lap_time_s for lap in again] == pytest.approx(times, abs=1e-6)


def test_a_reset_rule_ends_the_run_with_the_lap_it_was_in(env):
    laps = evaluate(env, Follower(env, off_at_progress=40.0), WorkerSettings(min_eval_trials=3, eval_continuous=True))
    assert [lap.final_status for lap in laps] == ["lap_complete", "off_track"]
    assert laps[1].lap_time_s is None and 40.0 < laps[1].progress < 60.0


def test_the_setting_is_read_from_workers_json_and_defaults_to_separate_trials():
    assert WorkerSettings().eval_continuous is False
    parsed = WorkerSettings.from_training_params({"RACER_EVAL_CONTINUOUS": "True"}, "workers.json")
    assert parsed.eval_continuous is True
    with pytest.raises(ValueError, match="RACER_EVAL_CONTINUOUS"):
        WorkerSettings.from_training_params({"RACER_EVAL_CONTINUOUS": "sometimes"}, "workers.json")
