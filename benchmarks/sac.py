"""`python -m benchmarks sac`: gradient steps/s of the SAC update (shallow camera network, batch 64), the project trainer
against a plain sequential step, and what that means for an iteration: DeepRacer's SAC takes one gradient step per
transition, so the trainer's time per iteration is transitions / steps-per-second, against the rollout workers' time
to collect them.

One synthetic iteration (camera frames with random pixels, continuous actions, rewards) fills the replay memory, an
untimed warm-up step runs on each path (oneDNN primitive creation), then the two paths alternate `--repeats` times,
`--steps` timed gradient steps each, from the same weights. `gradient_steps_per_s` counts steps of
`SACLearner._train` (sample, three losses, one Adam step); `baseline_gradient_steps_per_s` counts
`plain_sac_step`: the same losses computed one network after another on `--threads` intra-op threads (default: all
of the process's CPUs, torch's own default), the Q head's weight gradient of the policy loss computed and thrown away.
`transitions_per_s_at_one_update` is the trainer's rate again: the experience rate it keeps up with at DeepRacer's
one update per transition. `*_cpu_s_per_step` are process CPU seconds (OpenMP spin-waits included);
`policy_thread_cpu_s_per_step` and `critic_thread_cpu_s_per_step` split the trainer's between its two threads (a
step's wall time on two free cores is at least the larger).
"""

from __future__ import annotations

import copy
import json
import os
import platform
import statistics
import sys
import time
from dataclasses import replace

import click
import numpy as np
import torch
from torch import nn

from racer.options.trainer import device_option
from racer.options.training import seed_option
from racer.shared.deepracer.hyperparameters import Hyperparameters
from racer.shared.deepracer.model_metadata import parse_model_metadata
from racer.shared.episode import Episode
from racer.shared.policy.factory import build_network_for_metadata
from racer.trainer.device import DeviceError, describe_device, resolve_device
from racer.trainer.ppo import HUBER_DELTA
from racer.trainer.replay_buffer import ReplayBatch
from racer.trainer.sac import SACLearner, SACSettings

__all__ = ["METADATA", "plain_sac_step", "sac_bench_command", "synthetic_episodes"]

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


def plain_sac_step(trainer: SACLearner, batch: ReplayBatch) -> dict[str, float]:
    """The textbook step, one network after another on the calling thread: the baseline of the bench and the
    reference the trainer's step is tested against (same losses, same Adam). Returns the losses; the gradients stay
    in `.grad` until the next step."""
    hp, nets = trainer.hyperparameters, trainer.networks
    trainer.optimizer.zero_grad(set_to_none=True)
    sample = nets.sample(batch.observations, trainer.generator)
    q_features = nets.q_features(batch.observations)
    q1_new, q2_new = nets.q_values(q_features.detach(), sample.action)
    min_q_new = torch.min(q1_new, q2_new)
    policy_loss = (hp.sac_alpha * sample.log_prob - min_q_new).mean()
    policy_loss.backward()
    for parameter in nets.q_head.parameters():
        parameter.grad = None
    value_target = (min_q_new - hp.sac_alpha * sample.log_prob).detach()
    value = nets.value(batch.observations)
    if hp.loss_type == "huber":
        value_loss = nn.functional.huber_loss(value, value_target, delta=HUBER_DELTA)
    else:
        value_loss = nn.functional.mse_loss(value, value_target)
    td_target = batch.rewards + hp.discount_factor * (1.0 - batch.dones) * nets.target_value(batch.next_observations)
    q1, q2 = nets.q_values(q_features, batch.actions)
    q_loss = 0.5 * (q1 - td_target).square().mean() + 0.5 * (q2 - td_target).square().mean()
    (value_loss + q_loss).backward()
    trainer.optimizer.step()
    return {
        "policy": float(policy_loss.detach()),
        "q": float(q_loss.detach()),
        "v": float(value_loss.detach()),
        "entropy": -float(sample.log_prob.detach().mean()),
        "mean_q": float(min_q_new.detach().mean()),
    }


def _time_trainer(trainer: SACLearner, steps: int, batch_size: int) -> tuple[float, float, float]:
    """Wall, process CPU and this (the policy) thread's CPU seconds; the critic thread has the rest."""
    started, cpu_started, thread_started = time.perf_counter(), time.process_time(), time.thread_time()
    trainer._train(steps, batch_size)
    return time.perf_counter() - started, time.process_time() - cpu_started, time.thread_time() - thread_started


def _time_plain(trainer: SACLearner, steps: int, batch_size: int, threads: int) -> tuple[float, float]:
    previous = torch.get_num_threads()
    torch.set_num_threads(threads)
    try:
        started, cpu_started = time.perf_counter(), time.process_time()
        for _ in range(steps):
            plain_sac_step(trainer, trainer.replay.sample(batch_size, trainer.rng))
        return time.perf_counter() - started, time.process_time() - cpu_started
    finally:
        torch.set_num_threads(previous)


@click.command(name="sac")
@click.option("--steps", type=click.IntRange(1), default=50, show_default=True, help="Timed gradient steps per run.")
@click.option("--batch-size", type=click.Choice(["32", "64", "128"]), default="64", show_default=True)
@click.option(
    "--threads",
    type=click.IntRange(1),
    default=None,
    help="Intra-op threads of the plain baseline (default: the CPUs this process may use).",
)
@click.option("--threads-per-tower", type=click.IntRange(1), default=None, help="The trainer's (default: half).")
@click.option("--repeats", type=click.IntRange(1), default=3, show_default=True, help="Alternating runs per path.")
@seed_option
@device_option
def sac_bench_command(
    steps: int,
    batch_size: str,
    threads: int | None,
    threads_per_tower: int | None,
    repeats: int,
    seed: int,
    device: str,
) -> None:
    """One SAC iteration's gradient steps: steps/s on the shallow camera network, the trainer (on `--device`) vs a
    plain step on the CPU."""
    try:
        trainer_device = str(resolve_device(device))
    except DeviceError as error:
        raise click.UsageError(str(error)) from error
    torch.manual_seed(seed)
    batch = int(batch_size)
    threads = threads or len(os.sched_getaffinity(0))
    networks = build_network_for_metadata(parse_model_metadata(METADATA, "bench"))
    settings = SACSettings(replay_memory_bytes=256 << 20, seed=seed, threads_per_tower=threads_per_tower)
    plain = SACLearner(copy.deepcopy(networks), Hyperparameters(batch_size=batch), settings)
    trainer = SACLearner(networks, Hyperparameters(batch_size=batch), replace(settings, device=trainer_device))
    episodes = synthetic_episodes(10, 100, seed)
    trainer.add_experience(episodes)
    plain.add_experience(episodes)
    trainer._train(1, batch)  # warm-up: oneDNN primitive creation
    _time_plain(plain, 1, batch, threads)
    trainer_runs, plain_runs = [], []
    for repeat in range(repeats):
        plain_runs.append(_time_plain(plain, steps, batch, threads))
        print(f"sac bench: run {repeat + 1}/{repeats} plain {steps / plain_runs[-1][0]:.2f} steps/s", file=sys.stderr)
        trainer_runs.append(_time_trainer(trainer, steps, batch))
        print(
            f"sac bench: run {repeat + 1}/{repeats} trainer {steps / trainer_runs[-1][0]:.2f} steps/s", file=sys.stderr
        )
    trainer_s = statistics.median(wall for wall, _, _ in trainer_runs)
    trainer_cpu_s = statistics.median(cpu for _, cpu, _ in trainer_runs)
    policy_thread_cpu_s = statistics.median(thread for _, _, thread in trainer_runs)
    plain_s = statistics.median(wall for wall, _ in plain_runs)
    click.echo(
        json.dumps(
            {
                "benchmark": "sac",
                "gradient_steps": steps,
                "repeats": repeats,
                "batch_size": batch,
                "gradient_steps_per_s": round(steps / trainer_s, 2),
                "baseline_gradient_steps_per_s": round(steps / plain_s, 2),
                "speedup": round(plain_s / trainer_s, 3),
                "transitions_per_s_at_one_update": round(steps / trainer_s, 2),
                "cpu_s_per_step": round(trainer_cpu_s / steps, 4),
                "policy_thread_cpu_s_per_step": round(policy_thread_cpu_s / steps, 4),
                "critic_thread_cpu_s_per_step": round((trainer_cpu_s - policy_thread_cpu_s) / steps, 4),
                "baseline_cpu_s_per_step": round(statistics.median(cpu for _, cpu in plain_runs) / steps, 4),
                "precision": trainer.settings.precision.value,
                "device": describe_device(trainer.device),
                "baseline_device": "cpu",
                "threads_per_tower": settings.threads_per_tower or max(1, len(os.sched_getaffinity(0)) // 2),
                "baseline_threads": threads,
                "load_average_1min": round(os.getloadavg()[0], 2),
                "cpu": platform.processor() or platform.machine(),
            }
        )
    )
