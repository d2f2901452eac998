"""`--device`: auto, cpu and cuda resolve as documented, and cuda without a GPU is refused before anything starts."""

from __future__ import annotations

import copy
import math
import os
import subprocess
import sys

import numpy as np
import pytest
import torch

from benchmarks.sac import METADATA as SAC_METADATA
from benchmarks.sac import synthetic_episodes as sac_episodes
from racer.shared.deepracer.hyperparameters import Hyperparameters
from racer.shared.deepracer.model_metadata import parse_model_metadata
from racer.shared.policy.checkpoint_tensors import tensors_from_bytes, tensors_to_bytes
from racer.shared.policy.factory import build_network_for_metadata
from racer.shared.policy.onnx_export import export_onnx
from racer.trainer.device import DeviceError, cuda_absence_reason, resolve_device
from racer.trainer.ppo import PPOLearner, PPOSettings, make_training_batch
from racer.trainer.sac import SACLearner, SACSettings
from tests.trainer.ppo_task import random_episodes, task_network


def no_gpu() -> str:
    return "no NVIDIA GPU here"


def test_cpu_is_always_the_cpu():
    assert resolve_device("cpu", absence_reason=lambda: None) == torch.device("cpu")


def test_auto_is_the_gpu_when_there_is_one_else_the_cpu():
    assert resolve_device("auto", absence_reason=lambda: None) == torch.device("cuda")
    assert resolve_device("auto", absence_reason=no_gpu) == torch.device("cpu")


def test_cuda_without_a_gpu_says_why_and_what_to_do():
    with pytest.raises(DeviceError, match=r"--device cuda: no NVIDIA GPU here\. Train on the CPU with --device cpu"):
        resolve_device("cuda", absence_reason=no_gpu)
    with pytest.raises(DeviceError, match="choose one of auto, cpu, cuda"):
        resolve_device("tpu", absence_reason=no_gpu)


def test_racer_train_refuses_cuda_before_anything_starts(tmp_path):
    """CUDA_VISIBLE_DEVICES="" hides any GPU, so this holds on every machine: nothing is written, no process starts."""
    environment = {**os.environ, "CUDA_VISIBLE_DEVICES": "", "RACER_STORE": str(tmp_path / "store")}
    result = subprocess.run(
        [sys.executable, "-m", "racer.cli", "train", "--device", "cuda", "--max-minutes", "1", "--viewer-port", "0"],
        cwd=tmp_path,
        env=environment,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 2, result.stderr
    assert "--device cuda:" in result.stderr and "finds no CUDA device" in result.stderr
    assert list(tmp_path.iterdir()) == []


def test_trainer_refuses_cuda_before_connecting(tmp_path):
    """racer trainer with an unreachable Redis: the device error comes first, at once."""
    environment = {**os.environ, "CUDA_VISIBLE_DEVICES": "", "RACER_REDIS_URL": "redis://127.0.0.1:1/0"}
    result = subprocess.run(
        [sys.executable, "-m", "racer.cli", "trainer", "--model-prefix", "m", "--custom-files", str(tmp_path)]
        + ["--device", "cuda"],
        env=environment,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 2, result.stderr
    assert "finds no CUDA device" in result.stderr


@pytest.mark.skipif(cuda_absence_reason() is not None, reason="needs a CUDA device (run on a GPU machine)")
def test_a_ppo_update_on_the_gpu_lands_where_the_cpu_update_does():
    """Same seed, same episodes, same minibatches: the GPU-updated policy is the CPU-updated one to within float
    rounding, measured as the KL between them against the KL the update itself moved the policy by (Adam turns
    rounding on near-zero gradients into whole steps, so single weights may differ by a learning rate)."""
    network = task_network(num_actions=3, seed=0)
    episodes = random_episodes(network, [100, 90, 66], np.random.default_rng(1))
    hyperparameters = Hyperparameters(batch_size=64, num_epochs=2, lr=3e-4)
    on_cpu = PPOLearner(copy.deepcopy(network), hyperparameters, PPOSettings(seed=0, device="cpu"))
    on_gpu = PPOLearner(copy.deepcopy(network), hyperparameters, PPOSettings(seed=0, device="cuda"))
    cpu_stats, gpu_stats = on_cpu.update(episodes), on_gpu.update(episodes)
    assert [s.minibatches for s in cpu_stats] == [s.minibatches for s in gpu_stats]
    observations = make_training_batch(episodes, network.input_names).observations
    with torch.no_grad():
        before = network.distribution(observations).probs
        after_cpu = on_cpu.network.distribution(observations).probs
        after_gpu = on_gpu.network.distribution({k: v.cuda() for k, v in observations.items()}).probs.cpu()
    update_kl = float((before * (before / after_cpu).log()).sum(1).mean())
    device_kl = float((after_cpu * (after_cpu / after_gpu).log()).sum(1).mean())
    assert update_kl > 1e-4
    assert device_kl < 0.01 * update_kl, (device_kl, update_kl)


@pytest.mark.skipif(cuda_absence_reason() is not None, reason="needs a CUDA device (run on a GPU machine)")
def test_a_gpu_trained_network_is_saved_as_the_same_files():
    """Weights and the ONNX inference model come from host copies; the network stays on the GPU."""
    network = task_network(num_actions=3, seed=0)
    on_gpu = PPOLearner(
        copy.deepcopy(network), Hyperparameters(batch_size=64, num_epochs=1), PPOSettings(device="cuda")
    )
    saved = tensors_from_bytes(tensors_to_bytes(on_gpu.network.state_dict()))
    assert all(tensor.device.type == "cpu" for tensor in saved.values())
    assert export_onnx(on_gpu.network) == export_onnx(network)
    assert next(on_gpu.network.parameters()).device.type == "cuda"


@pytest.mark.skipif(cuda_absence_reason() is not None, reason="needs a CUDA device (run on a GPU machine)")
def test_sac_gradient_steps_run_on_the_gpu():
    metadata = parse_model_metadata(SAC_METADATA, "test")
    learner = SACLearner(
        build_network_for_metadata(metadata), Hyperparameters(batch_size=32), SACSettings(device="cuda", seed=0)
    )
    stats = learner.update(sac_episodes(4, 40, seed=0))
    assert stats and math.isfinite(stats[0].policy_loss)
    assert next(learner.network.parameters()).device.type == "cuda"
