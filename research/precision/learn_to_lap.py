"""Does a tower precision change what PPO learns? Env steps to a lap, fp32 against bf16, in one process.

`python -m benchmarks time-to-lap` runs the whole system (four worker processes, four worlds), so which worker plays which
episode depends on timing and no two runs see the same data. This study takes timing out: one process, one env
(re:Invent 2018, base world, the time-to-lap bench's five actions at 1 m/s and its recipe: 20 episodes, 3 epochs,
discount 0.99, the AWS centre-line reward), episodes played one after another with a seeded generator, then one PPO
update, then three greedy evaluation laps from 0, 1/3 and 2/3 of the lap. With one seed, fp32 and bf16 start from the
same weights and the same first batch, so any difference is the arithmetic's. It also compares the first update's
outcome on that real batch (benchmarks.precision_agreement). bf16 is emulated where the CPU lacks it: slower, same
rounding, so the learning effect shows on any machine.
"""

from __future__ import annotations

import json
import statistics
import sys
import time
from pathlib import Path

import click
import numpy as np
import torch

from benchmarks.precision_agreement import update_agreement
from benchmarks.time_to_lap_race_types import time_to_lap_hyperparameters
from benchmarks.workdir import cpu_description
from racer.shared.deepracer.hyperparameters import parse_hyperparameters
from racer.shared.deepracer.model_metadata import parse_model_metadata
from racer.shared.episode_loop import play_episode
from racer.shared.policy.networks import ActorCritic, build_actor_critic
from racer.shared.sim.config import EnvConfig
from racer.shared.sim.env import DeepRacerEnv
from racer.trainer.ppo import PPOLearner, PPOSettings
from racer.trainer.precision import PRECISION_NAMES, Precision
from research import data_option

EVALUATION_STARTS = (0.0, 1 / 3, 2 / 3)


def _metadata():
    return parse_model_metadata(
        {
            "action_space": [
                {"steering_angle": angle, "speed": 1.0, "index": i} for i, angle in enumerate([-30, -15, 0, 15, 30])
            ],
            "action_space_type": "discrete",
            "sensor": ["FRONT_FACING_CAMERA"],
            "neural_network": "DEEP_CONVOLUTIONAL_NETWORK_SHALLOW",
            "training_algorithm": "clipped_ppo",
            "version": "5",
        }
    )


class _TorchPolicy:
    """The network's fp32 policy, sampled or greedy, as the rollout workers' ONNX policy acts."""

    def __init__(self, network: ActorCritic):
        self.network = network

    def act(self, observation, greedy, generator, epsilon=0.0):
        with torch.no_grad():
            inputs = {name: torch.from_numpy(array[None]) for name, array in observation.items()}
            probabilities = self.network.distribution(inputs).probs[0].numpy().astype(np.float64)
        probabilities /= probabilities.sum()
        action = int(np.argmax(probabilities)) if greedy else int(generator.choice(len(probabilities), p=probabilities))
        return action, float(np.log(probabilities[action]))


def learn_to_lap(env: DeepRacerEnv, precision: Precision, seed: int, max_iterations: int) -> dict:
    """Train from scratch in this precision until 3 of 3 greedy laps; the env steps and iterations it took."""
    torch.manual_seed(seed)
    network = build_actor_critic(env.config.model_metadata)
    hyperparameters = parse_hyperparameters(time_to_lap_hyperparameters("time-trial", "clipped_ppo", None))[0]
    trainer = PPOLearner(network, hyperparameters, PPOSettings(seed=seed, threads_per_tower=1, precision=precision))
    policy, generator = _TorchPolicy(network), np.random.default_rng(seed)
    env_steps, first_agreement = 0, None
    for iteration in range(1, max_iterations + 1):
        episodes = [
            play_episode(
                env, policy, greedy=False, generator=generator, policy_version=iteration, worker_id=0, world="base",
                episode_index=i,
            ).episode
            for i in range(hyperparameters.num_episodes_between_training)
        ]  # fmt: skip
        env_steps += sum(episode.steps for episode in episodes)
        if iteration == 1 and precision is not Precision.FP32:
            first_agreement = update_agreement(network, hyperparameters, episodes, precision, seed).to_dict()
        trainer.update(episodes)
        laps = [
            play_episode(
                env, policy, greedy=True, generator=generator, policy_version=iteration, worker_id=0, world="base",
                episode_index=0, start_ndist=start,
            )
            for start in EVALUATION_STARTS
        ]  # fmt: skip
        completed = sum(lap.lap_completed for lap in laps)
        progress = float(np.mean([lap.progress for lap in laps]))
        print(f"precision: {precision.value} seed {seed} iteration {iteration}: {env_steps} env steps, "
              f"{completed}/3 laps, mean progress {progress:.1f} %", file=sys.stderr, flush=True)  # fmt: skip
        if completed == len(EVALUATION_STARTS):
            return {"env_steps": env_steps, "iterations": iteration, "first_update_agreement": first_agreement}
    return {"env_steps": None, "iterations": None, "env_steps_trained": env_steps, "first_update_agreement": None}


@click.command(name="precision")
@data_option("routes/reinvent_base.npy, reward_functions/awsdoc_example_1.py")
@click.option("--precision", "precisions", multiple=True, type=click.Choice(PRECISION_NAMES), default=PRECISION_NAMES)
@click.option("--seed", "seeds", multiple=True, type=int, default=(0, 1, 2), show_default=True)
@click.option("--max-iterations", default=20, show_default=True, help="Give up on a seed after this many updates.")
def precision_command(data: Path, precisions: tuple[str, ...], seeds: tuple[int, ...], max_iterations: int) -> None:
    """Env steps until 3 of 3 greedy laps, per precision and seed, in one deterministic process; one JSON line."""
    torch.set_num_threads(1)
    env = DeepRacerEnv(
        EnvConfig(
            track=data / "routes" / "reinvent_base.npy",
            world="base",
            model_metadata=_metadata(),
            reward_function_path=data / "reward_functions" / "awsdoc_example_1.py",
        )
    )
    started = time.monotonic()
    results: dict[str, dict[str, dict]] = {}
    try:
        for name in precisions:
            results[name] = {str(seed): learn_to_lap(env, Precision(name), seed, max_iterations) for seed in seeds}
    finally:
        env.close()
    medians = {}
    for name, by_seed in results.items():
        steps = [run["env_steps"] if run["env_steps"] is not None else float("inf") for run in by_seed.values()]
        medians[name] = statistics.median(steps)
    click.echo(
        json.dumps(
            {
                "study": "precision",
                "cpu": cpu_description(),
                "median_env_steps_to_lap": {k: (None if v == float("inf") else v) for k, v in medians.items()},
                "runs": results,
                "wall_s": round(time.monotonic() - started),
            }
        )
    )
