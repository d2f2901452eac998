"""A worker's envs (their counts' defaults: racer.options.training): how `envs` envs of one world share the starts one env would
have, and their random streams. A worker steps its envs in lockstep (racer.shared.episode_loop)."""

from __future__ import annotations

import dataclasses

import numpy as np

from racer.shared.sim.config import EnvConfig


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
