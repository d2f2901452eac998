"""How the transfer bench drives a checkpoint: greedily, closed loop, from evenly spaced starts under evaluation
rules without resets; laps and mean progress."""

from __future__ import annotations

import numpy as np
import torch

from benchmarks.real_models import RealModel
from racer.shared.sim.config import EnvConfig
from racer.shared.sim.env import DeepRacerEnv

MAX_STEPS_PER_START = 2000
"""Far more than a lap of re:Invent 2018 at 1 m/s takes (about 260 steps at 15 Hz)."""


def greedy_action(network: torch.nn.Module, camera: str, grey: np.ndarray) -> int:
    with torch.no_grad():
        probabilities = network.distribution({camera: torch.from_numpy(np.ascontiguousarray(grey)[None])}).probs
    return int(probabilities[0].argmax())


def drive(model: RealModel, config: EnvConfig, starts: int, start_offset: tuple[float, float] = (0.0, 0.0)) -> dict:
    """Greedy laps from `starts` evenly spaced places, evaluation rules, no resets; `start_offset` (metres, radians
    to the left) moves every start off the centre line (the robustness table)."""
    env = DeepRacerEnv(config)
    camera = model.metadata.camera_sensor
    progress, steps_driven = [], []
    options = {"evaluation": True, "start_offset": start_offset} if any(start_offset) else {"evaluation": True}
    try:
        for k in range(starts):
            observation, _ = env.reset(seed=1, options={**options, "start_ndist": k / starts})
            done, steps, info = False, 0, {"progress": 0.0}
            while not done and steps < MAX_STEPS_PER_START:
                observation, _, terminated, truncated, info = env.step(
                    greedy_action(model.network, camera, observation[camera])
                )
                done, steps = terminated or truncated, steps + 1
            progress.append(float(info["progress"]))
            steps_driven.append(steps)
    finally:
        env.close()
    return {
        "laps": int(sum(p >= 100.0 for p in progress)),
        "starts": starts,
        "mean_progress": round(float(np.mean(progress)), 1),
        "progress_per_start": [round(p, 1) for p in progress],
    }
