"""`racer bench sac`: gradient steps/s of the SAC update (shallow camera network, batch 64), and what that means for
an iteration: DeepRacer's SAC takes one gradient step per transition, so the trainer's time per iteration is
transitions / steps-per-second, against the rollout workers' time to collect them.

One synthetic iteration (camera frames with random pixels, continuous actions, rewards) fills the replay memory, an
untimed warm-up step runs, then `--steps` timed gradient steps. `gradient_steps_per_s` counts steps of
`SACTrainer._train` (sample, three losses, one Adam step); `transitions_per_s_at_one_update` is the same number: the
experience rate the trainer keeps up with at DeepRacer's one update per transition.
"""

from __future__ import annotations

import json
import platform
import time

import click
import numpy as np
import torch

from racer.shared.deepracer.hyperparameters import Hyperparameters
from racer.shared.deepracer.model_metadata import parse_model_metadata
from racer.shared.episode import Episode
from racer.shared.policy.factory import build_network_for_metadata
from racer.trainer.sac import SACSettings, SACTrainer

METADATA = {
    "action_space": {"steering_angle": {"low": -30, "high": 30}, "speed": {"low": 1, "high": 2}},
    "action_space_type": "continuous",
    "training_algorithm": "sac",
    "sensor": ["FRONT_FACING_CAMERA"],
    "neural_network": "DEEP_CONVOLUTIONAL_NETWORK_SHALLOW",
    "version": "5",
}


def synthetic_episodes(count: int, steps: int, seed: int) -> list[Episode]:
    rng = np.random.default_rng(seed)
    return [
        Episode(
            observations={"FRONT_FACING_CAMERA": rng.integers(0, 256, (steps, 120, 160, 1), dtype=np.uint8)},
            actions=rng.uniform(-1, 1, (steps, 2)).astype(np.float32),
            rewards=rng.uniform(0, 1, steps).astype(np.float32),
            log_probs=np.zeros(steps, np.float32),
            policy_version=0,
            worker_id=0,
            world="base",
        )
        for _ in range(count)
    ]


@click.command(name="sac")
@click.option("--steps", type=click.IntRange(1), default=200, show_default=True, help="Timed gradient steps.")
@click.option("--batch-size", type=click.Choice(["32", "64", "128"]), default="64", show_default=True)
@click.option("--threads", type=click.IntRange(1), default=None, help="torch threads (default: torch's).")
@click.option("--seed", type=int, default=0, show_default=True)
def sac_bench_command(steps: int, batch_size: str, threads: int | None, seed: int) -> None:
    """One SAC iteration's gradient steps: steps/s on the shallow camera network."""
    torch.manual_seed(seed)
    networks = build_network_for_metadata(parse_model_metadata(METADATA, "bench"))
    trainer = SACTrainer(
        networks,
        Hyperparameters(batch_size=int(batch_size)),
        SACSettings(replay_memory_bytes=256 << 20, seed=seed, threads=threads),
    )
    trainer.add_experience(synthetic_episodes(10, 100, seed))
    trainer._train(1, int(batch_size))  # warm-up: oneDNN primitive creation
    started, cpu_started = time.perf_counter(), time.process_time()
    trainer._train(steps, int(batch_size))
    wall_s, cpu_s = time.perf_counter() - started, time.process_time() - cpu_started
    click.echo(
        json.dumps(
            {
                "benchmark": "sac",
                "gradient_steps": steps,
                "batch_size": int(batch_size),
                "gradient_steps_per_s": round(steps / wall_s, 2),
                "transitions_per_s_at_one_update": round(steps / wall_s, 2),
                "cpu_s_per_step": round(cpu_s / steps, 4),
                "bf16_towers": trainer.tower_dtype is not None,
                "torch_threads": torch.get_num_threads(),
                "cpu": platform.processor() or platform.machine(),
            }
        )
    )
