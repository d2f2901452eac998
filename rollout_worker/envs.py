"""A worker's envs: how many (and how many workers), how `envs` envs of one world share the starts one env would
have, and their random streams. A worker steps its envs in lockstep (racer.shared.episode_loop)."""

from __future__ import annotations

import dataclasses
import os

import numpy as np

from racer.shared.sim.config import EnvConfig

DEFAULT_ENVS_PER_WORKER = 4
"""Per-frame inference cost falls steeply from batch 1 to 4 and less after (README, Benchmarks): the dense layer's
weights are read once per call. With the default 4 workers and 20 episodes per iteration more envs per worker would
mostly sit idle (an iteration has fewer episodes than 4 x 8 env slots), so 4 stays the default."""


DEFAULT_WORKERS = 4
"""Rollout workers of `racer train` on any machine: one per world. Not the core count: which worker plays which
episode shapes the run, and a default may not make runs differ between machines."""


def default_workers() -> int:
    """One worker per core at least, so every core has envs to step; four at least, one per world."""
    return max(4, len(os.sched_getaffinity(0)))


def spread_env_configs(config: EnvConfig, count: int) -> list[EnvConfig]:
    """`count` envs that together start where one env would over `count` times as many episodes: env j starts j
    round-robin steps after the first and advances `count` steps per episode (directions alternate to match)."""
    if count == 1:
        return [config]
    configs = []
    for j in range(count):
        configs.append(
            dataclasses.replace(
                config,
                start_position_offset=(
                    config.start_position_offset
                    + (j * config.round_robin_advance_dist if config.change_start_position else 0.0)
                )
                % 1.0,
                round_robin_advance_dist=count * config.round_robin_advance_dist,
                reverse_dir=config.reverse_dir != (config.alternate_driving_direction and j % 2 == 1),
                alternate_driving_direction=config.alternate_driving_direction and count % 2 == 1,
            )
        )
    return configs


def env_generator(seed: int, index: int) -> np.random.Generator:
    """Env 0 samples as a single-env worker always did; the others get their own streams."""
    return np.random.default_rng(seed if index == 0 else (seed, index))
