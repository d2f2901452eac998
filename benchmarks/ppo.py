"""`python -m benchmarks ppo`: samples/s of one PPO update, the project trainer against a plain fp32 eager baseline.

Both run in the same process on the same synthetic iteration (shallow network, FRONT_FACING_CAMERA, 5 discrete
actions; default 4000 transitions, 10 epochs, batch 64), from the same initial weights and the same minibatch
order. `samples_per_s` = transitions x epochs / wall seconds of `PPOLearner.update` (GAE, the old-policy pass and
the epochs, everything the trainer does per iteration); `baseline_samples_per_s` is the same for
`plain_ppo_update`, the textbook implementation: a deep-copied old network evaluated per minibatch, the default
single-tensor Adam loop, no NaN checks, the towers one after the other with `--threads` intra-op threads. Both get
the same cores and use the same network module (channels-last), so the speedup counts only what the update does
differently: policy and value towers on one core each (`PPOSettings.threads_per_tower`), the fused Adam kernel, and
one old-policy pass per update instead of one per minibatch. The trainer is timed in both precisions it offers
(`PPOSettings.precision`: fp32, the default, and bf16 towers), and `agreement` says how far the bf16 update lands from
the fp32 one on the same batch (benchmarks.precision_agreement). Neither path is compiled (torch.compile is slower
here, so there is no compile time to amortise).
A small untimed warm-up update runs first on each path (oneDNN primitive creation). With `--repeats` > 1 the two
paths alternate and medians are reported; `*_cpu_s` are process CPU seconds (OpenMP spin-waits included), less
sensitive than wall time to other processes on the same cores. `update_share_of_iteration`: the update's share of
an iteration that first collects the same transitions at `--experience-steps-per-s` (the workers wait meanwhile:
PPO is on-policy); `python -m benchmarks throughput` measures the same share in a real run.
"""

from __future__ import annotations

import copy
import json
import platform
import statistics
import sys
import time

import click
import numpy as np
import torch
from torch import nn

from benchmarks.precision_agreement import update_agreement
from benchmarks.workdir import cpu_description, native_bf16_available
from racer.options.trainer import device_option
from racer.options.training import seed_option
from racer.shared.deepracer.hyperparameters import Hyperparameters
from racer.shared.deepracer.model_metadata import parse_model_metadata
from racer.shared.episode import Episode
from racer.shared.policy.networks import ActorCritic, build_actor_critic
from racer.trainer.device import DeviceError, describe_device, resolve_device
from racer.trainer.gae import GAE_LAMBDA, compute_gae
from racer.trainer.ppo import (
    ADAM_BETAS,
    ADAM_EPSILON,
    ADVANTAGE_STD_EPSILON,
    CLIP_EPSILON,
    HUBER_DELTA,
    PPOLearner,
    PPOSettings,
    make_training_batch,
    minibatch_size_for,
    shuffled_minibatches,
)
from racer.trainer.precision import Precision

__all__ = ["bench_network", "plain_ppo_update", "ppo_bench_command", "synthetic_episodes"]

DEFAULT_EXPERIENCE_STEPS_PER_S = 800.0
"""Roughly what `python -m benchmarks throughput` gives the default system on 2 cores; pass the figure of your machine."""

EPISODE_STEPS = 100
"""Synthetic episodes are 100 steps long (DeepRacer's are 20-300), so GAE sees many episode boundaries."""


def bench_network(num_actions: int = 5, seed: int = 0) -> ActorCritic:
    torch.manual_seed(seed)
    actions = [{"steering_angle": -30 + 60 * i / max(1, num_actions - 1), "speed": 1.0} for i in range(num_actions)]
    metadata = parse_model_metadata(
        {
            "action_space": actions,
            "sensor": ["FRONT_FACING_CAMERA"],
            "neural_network": "DEEP_CONVOLUTIONAL_NETWORK_SHALLOW",
            "version": "5",
        }
    )
    return build_actor_critic(metadata)


def synthetic_episodes(transitions: int, num_actions: int, seed: int = 0) -> list[Episode]:
    """Random camera frames, actions and rewards: the update's cost does not depend on what the pixels show."""
    rng = np.random.default_rng(seed)
    episodes = []
    for index, start in enumerate(range(0, transitions, EPISODE_STEPS)):
        steps = min(EPISODE_STEPS, transitions - start)
        episodes.append(
            Episode(
                observations={"FRONT_FACING_CAMERA": rng.integers(0, 256, size=(steps, 120, 160, 1), dtype=np.uint8)},
                actions=rng.integers(0, num_actions, size=steps).astype(np.int64),
                rewards=rng.uniform(0, 2, size=steps).astype(np.float32),
                log_probs=np.full(steps, -np.log(num_actions), dtype=np.float32),
                policy_version=0,
                worker_id=0,
                world="bench",
                episode_index=index,
            )
        )
    return episodes


def plain_ppo_update(
    network: ActorCritic, hyperparameters: Hyperparameters, episodes: list[Episode], seed: int
) -> list[dict[str, float]]:
    """The baseline: the same clipped-PPO update written the obvious way, fp32 eager, no speed work.

    Also an independent cross-check of `PPOLearner` (tests compare their results).
    """
    hp = hyperparameters
    old_network = copy.deepcopy(network).requires_grad_(False)  # "sync" the target network
    optimizer = torch.optim.Adam(network.parameters(), lr=hp.lr, betas=ADAM_BETAS, eps=ADAM_EPSILON, foreach=False)
    generator = torch.Generator().manual_seed(seed)
    batch = make_training_batch(episodes, network.input_names)

    with torch.no_grad():
        values = torch.cat(
            [network.value(batch.select(torch.arange(i, min(i + 256, batch.size)))) for i in range(0, batch.size, 256)]
        )
    advantages, targets = compute_gae(
        batch.rewards.numpy(), values.numpy(), batch.episode_ends.numpy(), hp.discount_factor, GAE_LAMBDA
    )
    advantages = torch.from_numpy(
        ((advantages - advantages.mean()) / (advantages.std() + ADVANTAGE_STD_EPSILON)).astype(np.float32)
    )
    targets = torch.from_numpy(targets.astype(np.float32))

    stats = []
    for epoch in range(hp.num_epochs):
        sums = {"surrogate": 0.0, "kl": 0.0, "entropy": 0.0, "value": 0.0}
        minibatches = shuffled_minibatches(batch.size, minibatch_size_for(batch.size, hp.batch_size), generator)
        for indices in minibatches:
            observations = batch.select(indices)
            actions = batch.actions[indices]
            with torch.no_grad():
                old = old_network.distribution(observations)
            new = network.distribution(observations)
            ratio = torch.exp(new.log_prob(actions) - old.log_prob(actions))
            advantage = advantages[indices]
            surrogate = -torch.min(
                ratio * advantage, torch.clamp(ratio, 1 - CLIP_EPSILON, 1 + CLIP_EPSILON) * advantage
            ).mean()
            value = network.value(observations)
            if hp.loss_type == "huber":
                value_loss = nn.functional.huber_loss(value, targets[indices], delta=HUBER_DELTA)
            else:
                value_loss = nn.functional.mse_loss(value, targets[indices])
            entropy = new.entropy().mean()
            loss = value_loss + surrogate - hp.beta_entropy * entropy
            optimizer.zero_grad()
            loss.backward()
            optimizer.step()
            sums["surrogate"] += surrogate.item()
            sums["kl"] += new.kl_from(old).mean().item()
            sums["entropy"] += entropy.item()
            sums["value"] += value_loss.item()
        stats.append({key: total / max(1, len(minibatches)) for key, total in sums.items()} | {"epoch": epoch})
    return stats


def _time_trainer(
    network: ActorCritic,
    hp: Hyperparameters,
    episodes: list[Episode],
    seed: int,
    threads: int,
    precision: Precision,
    device: str = "cpu",
) -> tuple[float, float]:
    """(wall s, CPU s) of one PPOLearner.update on `device`; on the CPU the two towers share the `threads` cores."""
    trainer = PPOLearner(
        network,
        hp,
        PPOSettings(seed=seed, threads_per_tower=max(1, threads // 2), precision=precision, device=device),
    )
    start, cpu_start = time.perf_counter(), time.process_time()
    trainer.update(episodes)
    return time.perf_counter() - start, time.process_time() - cpu_start


def _time_baseline(
    network: ActorCritic, hp: Hyperparameters, episodes: list[Episode], seed: int, threads: int
) -> tuple[float, float]:
    torch.set_num_threads(threads)
    start, cpu_start = time.perf_counter(), time.process_time()
    plain_ppo_update(network, hp, episodes, seed)
    return time.perf_counter() - start, time.process_time() - cpu_start


@click.command(name="ppo")
@click.option("--transitions", default=4000, show_default=True, help="Transitions in the iteration.")
@click.option("--epochs", default=10, show_default=True, help="num_epochs.")
@click.option("--batch-size", default=64, show_default=True, help="Minibatch size.")
@click.option("--actions", "num_actions", default=5, show_default=True, help="Discrete actions.")
@click.option(
    "--threads",
    default=2,
    show_default=True,
    help="Cores for each path: baseline intra-op threads; trainer threads_per_tower = threads // 2.",
)
@click.option("--repeats", default=1, show_default=True, help="Timed runs per path (alternating); medians reported.")
@seed_option
@click.option(
    "--agreement-transitions",
    default=640,
    show_default=True,
    help="Transitions of the batch on which the fp32 and bf16 updates are compared (0: skip the comparison).",
)
@click.option(
    "--experience-steps-per-s",
    default=DEFAULT_EXPERIENCE_STEPS_PER_S,
    show_default=True,
    help="The system's experience rate (`python -m benchmarks throughput`), for the update's share of an iteration.",
)
@device_option
def ppo_bench_command(
    transitions: int,
    epochs: int,
    batch_size: int,
    num_actions: int,
    threads: int,
    repeats: int,
    seed: int,
    agreement_transitions: int,
    experience_steps_per_s: float,
    device: str,
) -> None:
    """One PPO update: samples/s of the project trainer in fp32 and in bf16 vs a plain fp32 eager baseline, and
    how far the bf16 update lands from the fp32 one, as one JSON line."""
    try:
        trainer_device = str(resolve_device(device))
    except DeviceError as error:
        raise click.UsageError(str(error)) from error
    hp = Hyperparameters(
        batch_size=batch_size, num_epochs=epochs, lr=3e-4, beta_entropy=0.01, discount_factor=0.999, loss_type="huber"
    )
    initial = bench_network(num_actions, seed)
    episodes = synthetic_episodes(transitions, num_actions, seed)
    warm_up = synthetic_episodes(2 * batch_size, num_actions, seed + 1)
    warm_hp = Hyperparameters(batch_size=batch_size, num_epochs=1, lr=3e-4, loss_type="huber")
    print("ppo bench: warming up both paths", file=sys.stderr)
    for precision in Precision:
        _time_trainer(copy.deepcopy(initial), warm_hp, warm_up, seed, threads, precision, trainer_device)
    _time_baseline(copy.deepcopy(initial), warm_hp, warm_up, seed, threads)

    runs: dict[str, list[tuple[float, float]]] = {"baseline": [], **{p.value: [] for p in Precision}}
    for repeat in range(repeats):
        runs["baseline"].append(_time_baseline(copy.deepcopy(initial), hp, episodes, seed, threads))
        for precision in Precision:
            runs[precision.value].append(
                _time_trainer(copy.deepcopy(initial), hp, episodes, seed, threads, precision, trainer_device)
            )
        timings = ", ".join(f"{name} {timed[-1][0]:.1f} s" for name, timed in runs.items())
        print(f"ppo bench: run {repeat + 1}/{repeats}: {timings}", file=sys.stderr)
    samples = transitions * epochs
    trainer_s, trainer_cpu_s = zip(*runs[Precision.FP32.value], strict=True)
    bf16_s, bf16_cpu_s = zip(*runs[Precision.BF16.value], strict=True)
    baseline_s, baseline_cpu_s = zip(*runs["baseline"], strict=True)
    trainer_median, baseline_median = statistics.median(trainer_s), statistics.median(baseline_s)
    bf16_median = statistics.median(bf16_s)
    agreement = None
    if agreement_transitions > 0:
        print("ppo bench: comparing one bf16 update with the fp32 update on the same batch", file=sys.stderr)
        agreement = update_agreement(
            initial, hp, synthetic_episodes(agreement_transitions, num_actions, seed + 2), Precision.BF16, seed
        ).to_dict()
    print(
        json.dumps(
            {
                "benchmark": "ppo",
                "network": "DEEP_CONVOLUTIONAL_NETWORK_SHALLOW",
                "transitions": transitions,
                "epochs": epochs,
                "batch_size": batch_size,
                "actions": num_actions,
                "threads": threads,
                "repeats": repeats,
                "samples_per_s": round(samples / trainer_median, 1),
                "bf16_samples_per_s": round(samples / bf16_median, 1),
                "bf16_speedup_over_fp32": round(trainer_median / bf16_median, 3),
                "baseline_samples_per_s": round(samples / baseline_median, 1),
                "speedup": round(baseline_median / trainer_median, 3),
                # An iteration = collecting the transitions at the system's rate, then this update.
                "update_share_of_iteration": round(
                    trainer_median / (trainer_median + transitions / experience_steps_per_s), 3
                ),
                "experience_steps_per_s": experience_steps_per_s,
                "trainer_s": [round(s, 2) for s in trainer_s],
                "baseline_s": [round(s, 2) for s in baseline_s],
                "trainer_cpu_s": [round(s, 2) for s in trainer_cpu_s],
                "bf16_s": [round(s, 2) for s in bf16_s],
                "bf16_cpu_s": [round(s, 2) for s in bf16_cpu_s],
                "baseline_cpu_s": [round(s, 2) for s in baseline_cpu_s],
                "device": describe_device(torch.device(trainer_device)),
                "baseline_device": "cpu",
                "cpu_capability": torch.backends.cpu.get_cpu_capability(),
                "machine": platform.machine(),
                "torch": torch.__version__,
                "cpu": cpu_description(),
                "native_bf16": native_bf16_available(),
                "agreement": agreement,
                "fast_path": "policy/value towers on one core each, fused Adam, old policy once per update; "
                "channels-last in both paths; no torch.compile",
            }
        ),
        flush=True,
    )
