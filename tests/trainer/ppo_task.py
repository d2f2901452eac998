"""A tiny image task for PPO tests: the correct action is written in the picture.

Each episode is one step. The camera image shows a bright vertical bar in one of `num_actions` columns; choosing
the action with that index earns reward 1, anything else 0. A policy that reads the image gets 100 %.
"""

from __future__ import annotations

import numpy as np
import torch

from racer.shared.deepracer.model_metadata import parse_model_metadata
from racer.shared.episode import Episode
from racer.shared.policy.networks import ActorCritic, build_actor_critic

CAMERA = "FRONT_FACING_CAMERA"


def task_network(num_actions: int = 3, seed: int = 0, sensors=(CAMERA,), continuous: bool = False) -> ActorCritic:
    torch.manual_seed(seed)
    if continuous:
        action_space = {"steering_angle": {"low": -30, "high": 30}, "speed": {"low": 0.5, "high": 2.0}}
    else:
        action_space = [
            {"steering_angle": -30 + 60 * i / max(1, num_actions - 1), "speed": 1.0} for i in range(num_actions)
        ]
    data = {
        "action_space": action_space,
        "sensor": list(sensors),
        "neural_network": "DEEP_CONVOLUTIONAL_NETWORK_SHALLOW",
        "version": "5",
    }
    if continuous:
        data["action_space_type"] = "continuous"
    return build_actor_critic(parse_model_metadata(data))


def bar_images(labels: np.ndarray, num_actions: int, rng: np.random.Generator) -> np.ndarray:
    """uint8 (n, 120, 160, 1): noise background with a bright bar in column block `label`."""
    images = rng.integers(0, 100, size=(len(labels), 120, 160, 1), dtype=np.uint8)
    width = 160 // num_actions
    for i, label in enumerate(labels):
        images[i, :, label * width : (label + 1) * width - 8, 0] += 40
    return images


def observations_for(network: ActorCritic, images: np.ndarray, rng: np.random.Generator) -> dict[str, np.ndarray]:
    observations = {CAMERA: images}
    for spec in network.config.inputs:
        if spec.name != CAMERA:
            observations[spec.name] = rng.uniform(0.15, 1.0, size=(len(images), *spec.shape)).astype(np.float32)
    return observations


def play(
    network: ActorCritic, episodes: int, num_actions: int, rng: np.random.Generator, policy_version: int = 0
) -> list[Episode]:
    """Sample `episodes` one-step episodes with the current policy (batched inference, as many workers would)."""
    labels = rng.integers(0, num_actions, size=episodes)
    observations = observations_for(network, bar_images(labels, num_actions, rng), rng)
    with torch.inference_mode():
        probs = network.distribution({k: torch.from_numpy(v) for k, v in observations.items()}).probs.double().numpy()
    result = []
    for i in range(episodes):
        p = probs[i] / probs[i].sum()
        action = int(rng.choice(num_actions, p=p))
        result.append(
            Episode(
                observations={name: array[i : i + 1] for name, array in observations.items()},
                actions=np.array([action], dtype=np.int64),
                rewards=np.array([1.0 if action == labels[i] else 0.0], dtype=np.float32),
                log_probs=np.array([np.log(probs[i, action])], dtype=np.float32),
                policy_version=policy_version,
                worker_id=i % 2,
                world="bars",
                episode_index=i,
            )
        )
    return result


def greedy_accuracy(network: ActorCritic, num_actions: int, rng: np.random.Generator, samples: int = 300) -> float:
    labels = rng.integers(0, num_actions, size=samples)
    observations = observations_for(network, bar_images(labels, num_actions, rng), rng)
    with torch.inference_mode():
        chosen = network.distribution({k: torch.from_numpy(v) for k, v in observations.items()}).mode().numpy()
    return float(np.mean(chosen == labels))


def random_episodes(network: ActorCritic, lengths: list[int], rng: np.random.Generator) -> list[Episode]:
    """Multi-step episodes with random observations, actions and rewards (for mechanics tests, not learning)."""
    episodes = []
    for index, steps in enumerate(lengths):
        observations = {}
        for spec in network.config.inputs:
            if spec.kind == "camera":
                observations[spec.name] = rng.integers(0, 256, size=(steps, *spec.shape), dtype=np.uint8)
            else:
                observations[spec.name] = rng.uniform(0.15, 1.0, size=(steps, *spec.shape)).astype(np.float32)
        if network.config.is_continuous:
            actions = rng.uniform(-1, 1, size=(steps, 2)).astype(np.float32)
        else:
            actions = rng.integers(0, network.config.num_actions, size=steps).astype(np.int64)
        episodes.append(
            Episode(
                observations=observations,
                actions=actions,
                rewards=rng.normal(1.0, 1.0, size=steps).astype(np.float32),
                log_probs=np.full(steps, -1.0, dtype=np.float32),
                policy_version=0,
                worker_id=0,
                world="random",
                episode_index=index,
            )
        )
    return episodes
