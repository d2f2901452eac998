"""`python -m benchmarks rollout`: what batching buys one rollout worker, and which inference path is faster.

inference: one forward pass of the default model's network (custom_files/model_metadata.json, fresh weights) on one
thread at batch 1, 4 and 8, per frame: the checkpoint's ONNX graph with a free batch dimension (what workers use),
the same graph called once per frame at batch 1, and the PyTorch module.
rollout: one worker's loop (`racer.shared.episode_loop`: env steps, the batched ONNX forward pass, recording, and encoding each
finished episode as it would be sent) with 1, 4 and 8 envs, in alternating blocks so that other processes' load hits
all alike; process CPU ms per env step (llvmpipe's render thread included) is the figure to compare on a busy
machine, wall steps/s is printed beside it.
encoding: the CPU ms per frame and the size ratio of compressing the played frames with zstd level 1 (what the codec
sends) and with zlib level 1 (the other codec it decodes).
"""

from __future__ import annotations

import json
import tempfile
import threading
import time
import warnings
import zlib
from pathlib import Path

import click
import numpy as np
import onnxruntime
import torch
import zstandard

from racer.defaults import DEFAULT_CUSTOM_FILES
from racer.rollout_worker.worker import env_generator, spread_env_configs
from racer.shared.deepracer.model_metadata import load_model_metadata
from racer.shared.episode_loop import EpisodeLoop, EpisodeTicket, play_episodes
from racer.shared.policy.checkpoints import CheckpointStore
from racer.shared.policy.networks import build_actor_critic
from racer.shared.policy.onnx_export import export_onnx
from racer.shared.sim.env import DeepRacerEnv, EnvConfig
from racer.shared.store import LocalStore
from racer.shared.transport.codec import ZSTD_LEVEL, encode_episode

BATCHES = (1, 4, 8)
MAX_ENCODED_FRAMES = 1000


def _per_call_ms(call, repeats: int) -> float:
    call()
    start = time.perf_counter()
    for _ in range(repeats):
        call()
    return 1e3 * (time.perf_counter() - start) / repeats


def inference_costs(network, policy, repeats: int) -> dict:
    """ms per frame at each batch size for the three paths."""
    name = network.input_names[0]
    shape = network.config.inputs[0].shape
    options = onnxruntime.SessionOptions()
    options.intra_op_num_threads = options.inter_op_num_threads = 1
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        batch_one = onnxruntime.InferenceSession(export_onnx(network), options, providers=["CPUExecutionProvider"])
    rng = np.random.default_rng(0)
    costs = {}
    for batch in BATCHES:
        frames = rng.integers(0, 256, size=(batch, *shape)).astype(np.uint8)
        observations = [{name: frame} for frame in frames]
        as_float = frames.astype(np.float32)
        tensor = torch.from_numpy(as_float)
        with torch.inference_mode():
            torch_ms = _per_call_ms(lambda t=tensor: network.policy_output({name: t}), repeats)
        costs[f"batch_{batch}"] = {
            "onnx_batched_ms_per_frame": round(
                _per_call_ms(lambda o=observations: policy.policy_outputs(o), repeats) / batch, 3
            ),
            "onnx_one_call_per_frame_ms": round(
                _per_call_ms(
                    lambda f=as_float: [batch_one.run(None, {name: f[i : i + 1]}) for i in range(len(f))], repeats
                )
                / batch,
                3,
            ),
            "torch_batched_ms_per_frame": round(torch_ms / batch, 3),
        }
    return costs


def encoding_costs(frames: np.ndarray, repeats: int = 3) -> dict:
    """CPU ms per frame and compression ratio of zstd level 1 (the codec's) and zlib level 1 on rendered frames."""
    raw = np.ascontiguousarray(frames).tobytes()
    compressors = {
        "zstd_level_1": lambda: zstandard.ZstdCompressor(level=ZSTD_LEVEL).compress(raw),
        "zlib_level_1": lambda: zlib.compress(raw, 1),
    }
    costs = {}
    for name, compress in compressors.items():
        size = len(compress())
        start = time.process_time()
        for _ in range(repeats):
            compress()
        cpu_s = (time.process_time() - start) / repeats
        costs[name] = {"cpu_ms_per_frame": round(1e3 * cpu_s / len(frames), 4), "ratio": round(len(raw) / size, 2)}
    return costs


def rollout_costs(policy, config: EnvConfig, blocks: int, episodes_per_block: int, frames: list | None = None) -> dict:
    """`frames`, when given, receives the camera frames of the played episodes (for `encoding_costs`)."""
    rollouts = {}
    for count in BATCHES:
        envs = [DeepRacerEnv(c) for c in spread_env_configs(config, count)]
        for j, env in enumerate(envs):
            env.reset(seed=j)
        rollouts[count] = EpisodeLoop(policy, envs, [env_generator(0, j) for j in range(count)], greedy=False)
    totals = {count: [0, 0.0, 0.0] for count in rollouts}
    try:
        for block in range(blocks):
            for count, rollout in rollouts.items():
                left = [episodes_per_block]

                def next_episode(_index: int, left=left) -> EpisodeTicket | None:
                    if left[0] == 0:
                        return None
                    left[0] -= 1
                    return EpisodeTicket(0)

                def finished(_index: int, _ticket, recorder, count=count) -> None:
                    played = recorder.finish(
                        policy_version=0, worker_id=0, world="base", episode_index=0, simtrace_episode=0
                    )
                    totals[count][0] += played.steps
                    if frames is not None:
                        frames.extend(next(iter(played.episode.observations.values())))
                    encode_episode(played.episode)

                start, cpu_start = time.perf_counter(), time.process_time()
                play_episodes(rollout, next_episode, finished, threading.Event())
                totals[count][1] += time.perf_counter() - start
                totals[count][2] += time.process_time() - cpu_start
            click.echo(f"rollout bench: block {block + 1}/{blocks}", err=True)
    finally:
        for rollout in rollouts.values():
            for env in rollout.envs:
                env.close()
    return {
        f"envs_{count}": {
            "steps": steps,
            "wall_steps_per_s": round(steps / wall_s, 1),
            "cpu_ms_per_step": round(1e3 * cpu_s / steps, 3),
        }
        for count, (steps, wall_s, cpu_s) in totals.items()
    }


@click.command("rollout")
@click.option("--blocks", default=3, show_default=True, help="Alternating blocks per envs count.")
@click.option("--episodes-per-block", default=16, show_default=True)
@click.option("--repeats", default=200, show_default=True, help="Forward passes timed per inference figure.")
def rollout_bench_command(blocks: int, episodes_per_block: int, repeats: int) -> None:
    """Per-frame inference cost at batch 1/4/8 (ONNX batched, ONNX per frame, PyTorch) and one worker's CPU per env
    step with 1/4/8 envs; prints one JSON line."""
    torch.set_num_threads(1)
    custom = DEFAULT_CUSTOM_FILES
    metadata = load_model_metadata(custom / "model_metadata.json")
    torch.manual_seed(0)
    network = build_actor_critic(metadata).eval()
    with tempfile.TemporaryDirectory() as folder:
        checkpoints = CheckpointStore(LocalStore(Path(folder)), "bench")
        policy = checkpoints.load_inference_policy(checkpoints.save(0, 0, network, model_metadata=metadata))
    config = EnvConfig(model_metadata=metadata, reward_function_path=custom / "reward_function.py")
    frames: list[np.ndarray] = []
    result = {
        "network": metadata.neural_network,
        "inference": inference_costs(network, policy, repeats),
        "rollout": rollout_costs(policy, config, blocks, episodes_per_block, frames),
        "encoding": encoding_costs(np.stack(frames[:MAX_ENCODED_FRAMES])),
    }
    click.echo(json.dumps(result))
