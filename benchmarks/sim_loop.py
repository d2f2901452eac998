"""What the simulator benches (`python -m benchmarks sim`, with and without objects on the track) share: the reward
function they score with and the timed block of random-action env steps."""

from __future__ import annotations

import time

import numpy as np

from racer.shared.sim.env import DeepRacerEnv

BENCH_REWARD = """
def reward_function(params):
    width = params["track_width"]
    distance = params["distance_from_center"]
    if distance <= 0.1 * width:
        return 1.0
    if distance <= 0.25 * width:
        return 0.5
    if distance <= 0.5 * width:
        return 0.1
    return 1e-3
"""


def env_block(env: DeepRacerEnv, rng: np.random.Generator, steps: int) -> tuple[float, float]:
    """(wall seconds, process CPU seconds) for `steps` env steps."""
    start, cpu_start = time.perf_counter(), time.process_time()
    for _ in range(steps):
        _, _, terminated, truncated, _ = env.step(int(rng.integers(env.action_space.n)))
        if terminated or truncated:
            env.reset()
    return time.perf_counter() - start, time.process_time() - cpu_start
