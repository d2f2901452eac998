"""Several envs stepped together with one batched forward pass play exactly the episodes each env plays alone."""

from __future__ import annotations

import threading

import numpy as np
import pytest
import torch

from racer.rollout_worker.envs import env_generator, spread_env_configs
from racer.shared.deepracer.model_metadata import load_model_metadata
from racer.shared.episode_loop import EpisodeLoop, EpisodeTicket, play_episode, play_episodes
from racer.shared.policy.checkpoints import CheckpointStore
from racer.shared.policy.networks import build_actor_critic
from racer.shared.sim.env import DeepRacerEnv, EnvConfig
from racer.shared.store import LocalStore
from tests.conftest import write_custom_files

ENVS = 3
EPISODES_PER_ENV = 2
SEED = 7


@pytest.fixture(scope="module")
def setup(tmp_path_factory):
    folder = write_custom_files(tmp_path_factory.mktemp("custom") / "custom_files")
    metadata = load_model_metadata(folder / "model_metadata.json")
    torch.manual_seed(0)
    checkpoints = CheckpointStore(LocalStore(tmp_path_factory.mktemp("store")), "m")
    name = checkpoints.save(0, 0, build_actor_critic(metadata), model_metadata=metadata)
    config = EnvConfig(
        track="racer_oval",
        model_metadata=metadata,
        reward_function_path=folder / "reward_function.py",
        max_steps=12,  # short episodes: the test compares every step, not long drives
        round_robin_advance_dist=0.1,
    )
    return checkpoints.load_inference_policy(name), spread_env_configs(config, ENVS)


def make_envs(configs):
    envs = [DeepRacerEnv(config, wall_clock=lambda: 0.0) for config in configs]
    for j, env in enumerate(envs):
        env.reset(seed=SEED + 1000 * j)
    return envs


def without_wall_clock(rows):
    return [{k: v for k, v in row.items() if k != "wall_clock"} for row in rows]


def test_batched_and_single_env_rollouts_give_identical_episodes(setup):
    policy, configs = setup
    envs = make_envs(configs)
    try:
        left = {j: EPISODES_PER_ENV for j in range(ENVS)}
        batched: dict[int, list] = {j: [] for j in range(ENVS)}

        def next_episode(index):
            if left[index] == 0:
                return None
            left[index] -= 1
            return EpisodeTicket(number=index)

        def finished(index, ticket, recorder):
            batched[index].append(
                recorder.finish(policy_version=0, worker_id=0, world="base", episode_index=0, simtrace_episode=None)
            )

        loop = EpisodeLoop(policy, envs, [env_generator(SEED, j) for j in range(ENVS)], greedy=False)
        assert play_episodes(loop, next_episode, finished, threading.Event())
    finally:
        for env in envs:
            env.close()

    starts = set()
    for j, config in enumerate(configs):
        (env,) = make_envs([config])
        env.reset(seed=SEED + 1000 * j)
        generator = env_generator(SEED, j)
        try:
            alone = [
                play_episode(
                    env,
                    policy,
                    greedy=False,
                    generator=generator,
                    policy_version=0,
                    worker_id=0,
                    world="base",
                    episode_index=0,
                )
                for _ in range(EPISODES_PER_ENV)
            ]
        finally:
            env.close()
        assert len(batched[j]) == EPISODES_PER_ENV
        for mine, reference in zip(batched[j], alone, strict=True):
            for name, frames in reference.episode.observations.items():
                np.testing.assert_array_equal(mine.episode.observations[name], frames)
            np.testing.assert_array_equal(mine.episode.actions, reference.episode.actions)
            np.testing.assert_array_equal(mine.episode.log_probs, reference.episode.log_probs)
            np.testing.assert_array_equal(mine.episode.rewards, reference.episode.rewards)
            assert without_wall_clock(mine.simtrace_rows) == without_wall_clock(reference.simtrace_rows)
            starts.add((round(reference.simtrace_rows[0]["X"], 3), round(reference.simtrace_rows[0]["Y"], 3)))
    assert len(starts) == ENVS * EPISODES_PER_ENV  # every episode starts somewhere else on the lap


def test_spread_envs_start_where_one_env_would_over_as_many_episodes():
    base = EnvConfig(track="racer_oval", start_position_offset=0.05, round_robin_advance_dist=0.1)
    configs = spread_env_configs(base, 3)
    assert [round(c.start_position_offset, 6) for c in configs] == [0.05, 0.15, 0.25]
    assert [c.round_robin_advance_dist for c in configs] == [pytest.approx(0.3)] * 3
    alternating = EnvConfig(track="racer_oval", alternate_driving_direction=True)
    even = spread_env_configs(alternating, 4)  # one env's episodes n = j, j+4, ...: a fixed direction per env
    assert [c.reverse_dir for c in even] == [False, True, False, True]
    assert not any(c.alternate_driving_direction for c in even)
    odd = spread_env_configs(alternating, 3)  # n = j, j+3, ...: the direction flips every episode
    assert [c.reverse_dir for c in odd] == [False, True, False]
    assert all(c.alternate_driving_direction for c in odd)
