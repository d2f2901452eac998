"""The proof that one policy is one function everywhere: racer, the exported frozen graph run by TensorFlow, and the
OpenVINO IR and LiteRT (TFLite) models the cars make from it, fp32 and fp16, on frames racer's simulator renders.

The test suite runs a subset of the matrix (test_tensorflow_proof.py) and the examples of docs/custom-networks.md
(test_custom_graph_export.py). `python -m tests.model_io.tf_proof`, from the repository root, runs the whole matrix
(every network, every sensor set DRoA's validation accepts, PPO discrete, PPO continuous and SAC: 72 models) and
prints one JSON line; `--examples` runs the examples instead (tf_proof_examples.py: your own networks, batch-norm, a
two-frame stack, on DeepRacer's Gazebo frames). Frames are rendered in this process; every TensorFlow,
OpenVINO and LiteRT step runs in a TensorFlow process (`tool.py prove`) that takes its models one at a time (a stereo
DEEP policy network is 230 MB); `--processes` runs several side by side.
"""

from __future__ import annotations

import json
import sys
import tempfile
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import click
import numpy as np
import torch
from safetensors.numpy import save_file

from racer.model_io.tensorflow.convert import ExportJob, coach_graph_spec, coach_tensors, policy_scope
from racer.model_io.tensorflow.runner import run_tool, run_tools
from racer.shared.deepracer.model_metadata import NEURAL_NETWORKS, parse_model_metadata
from racer.shared.policy.factory import PolicyNetwork, build_network_for_metadata
from racer.shared.policy.networks import ActorCritic
from tests.model_io.tf_proof_examples import proof_action_space

__all__ = [
    "FP16_TOLERANCE",
    "FP32_TOLERANCE",
    "ModelSpec",
    "RUNTIMES",
    "SENSOR_SETS",
    "all_specs",
    "make_model",
    "render_frames",
    "run_proof",
    "summarize",
]

SENSOR_SETS: tuple[tuple[str, ...], ...] = tuple(
    (camera, *lidar)
    for camera in ("FRONT_FACING_CAMERA", "STEREO_CAMERAS")
    for lidar in ((), ("LIDAR",), ("SECTOR_LIDAR",), ("DISCRETIZED_SECTOR_LIDAR",))
)
"""The SimApp's validation_worker.get_transition_data: a front camera or stereo cameras, alone or with one lidar."""
RUNTIMES = ("tensorflow", "openvino_fp32", "litert_fp32", "openvino_fp16", "litert_fp16")
FP32_TOLERANCE = 1e-5
FP16_TOLERANCE = 1e-3
FP16_ULPS = 2
"""fp16 outputs agree to FP16_TOLERANCE, or to FP16_ULPS units in the last place of fp16 at the output's largest
magnitude where that is more: one fp16 step is 9.8e-4 between 1 and 2, so a continuous mean of 1.35 cannot be held
to 1e-3 where a probability of 0.1 (steps of 6e-5) can."""
FP16_SAME_ACTION = 0.99
PROVE_TIMEOUT_S_PER_MODEL = 1800.0
"""Wall time, generous: a 230 MB stereo model converts four ways in about ten minutes on 2 cores shared by other
work, and one TensorFlow process may hold a single such model."""


@dataclass(frozen=True)
class ModelSpec:
    neural_network: str
    sensors: tuple[str, ...]
    continuous: bool
    sac: bool = False
    """SAC (continuous only): the frozen graph's output is the policy's mean before tanh."""

    @property
    def key(self) -> str:
        kind = "sac" if self.sac else "continuous" if self.continuous else "discrete"
        return f"{self.neural_network}:{'+'.join(self.sensors)}:{kind}"

    def metadata(self) -> dict:
        return {
            "action_space": proof_action_space(self.continuous),
            "sensor": list(self.sensors),
            "neural_network": self.neural_network,
            "action_space_type": "continuous" if self.continuous else "discrete",
            "training_algorithm": "sac" if self.sac else "clipped_ppo",
            "version": "5",
            "lidar_config": {"num_sectors": 8, "num_values_per_sector": 4, "clipping_dist": 2.0},
        }


def all_specs() -> list[ModelSpec]:
    """PPO discrete, PPO continuous and SAC for every network and sensor set: 72 models."""
    return [
        ModelSpec(network, sensors, continuous, sac)
        for network in NEURAL_NETWORKS
        for sensors in SENSOR_SETS
        for continuous, sac in ((False, False), (True, False), (True, True))
    ]


def make_model(spec: ModelSpec, seed: int) -> PolicyNetwork:
    """A network with weights like a trained one's: RL Coach's 0.01-scaled continuous PPO head would give near-zero
    means, so the head is redrawn wider (SAC's Xavier-initialised head is wide already)."""
    torch.manual_seed(seed)
    model = build_network_for_metadata(parse_model_metadata(spec.metadata(), spec.key))
    if isinstance(model, ActorCritic):
        with torch.no_grad():
            model.policy_head.weight.normal_(0.0, 0.05)
    return model.eval()


def graph_output(model: PolicyNetwork, feeds: dict[str, torch.Tensor]) -> torch.Tensor:
    """What the frozen graph's output node computes: PPO's policy output, SAC's mean before tanh (racer's SAC
    drives tanh of it, as the SimApp's SAC head does after that node)."""
    if isinstance(model, ActorCritic):
        return model.policy_output(feeds)
    return model.policy_distribution(feeds)[0]


def render_frames(count: int) -> dict[str, np.ndarray]:
    """`count` observations per sensor, rendered while driving with random actions (reset when an episode ends)."""
    from racer.shared.sim.config import EnvConfig  # MuJoCo and Mesa: this process never imports TensorFlow
    from racer.shared.sim.env import DeepRacerEnv

    rendered: dict[str, np.ndarray] = {}
    for sensors in (
        ("FRONT_FACING_CAMERA", "LIDAR"),
        ("STEREO_CAMERAS", "SECTOR_LIDAR"),
        ("FRONT_FACING_CAMERA", "DISCRETIZED_SECTOR_LIDAR"),
    ):
        metadata = parse_model_metadata(ModelSpec(NEURAL_NETWORKS[0], sensors, False).metadata(), "proof metadata")
        env = DeepRacerEnv(EnvConfig(model_metadata=metadata), wall_clock=lambda: 1700000000.0)
        try:
            rng = np.random.default_rng(len(rendered))
            observation, _ = env.reset(seed=3)
            wanted = [sensor for sensor in sensors if sensor not in rendered]
            collected: dict[str, list[np.ndarray]] = {sensor: [] for sensor in wanted}
            while len(collected[wanted[0]]) < count:
                for sensor in wanted:
                    collected[sensor].append(np.asarray(observation[sensor]).copy())
                observation, _, terminated, truncated, _ = env.step(int(rng.integers(metadata.num_actions)))
                if terminated or truncated:
                    observation, _ = env.reset()
            rendered.update({sensor: np.stack(values).astype(np.float32) for sensor, values in collected.items()})
        finally:
            env.close()
    return rendered


def run_proof(
    specs: list,
    frames: dict[str, np.ndarray],
    runtimes: tuple[str, ...] = RUNTIMES,
    first_seed: int = 0,
    make: Callable[[Any, int], PolicyNetwork] = make_model,
    processes: int = 1,
) -> dict:
    """racer's policy outputs and every runtime's, per model key; `cpu_s`: TensorFlow-process CPU seconds per
    model and runtime (conversion included). `specs`: ModelSpec, or any spec with a `key` that `make` builds a
    network from (tf_proof_examples). `processes` TensorFlow processes side by side take the models in turn (model i
    goes to process i mod `processes`), one model in memory at a time each: most conversion steps use one core, so 2
    processes on 2 cores take about half the wall time. Model i's weights come from seed `first_seed` + i whatever
    the number of processes."""
    groups: list[list[dict]] = [[] for _ in range(max(1, min(processes, len(specs))))]
    with tempfile.TemporaryDirectory(prefix="racer-proof-") as folder:
        expected, requests = _prepared(specs, frames, Path(folder), first_seed, make)
        for index, request in enumerate(requests):
            groups[index % len(groups)].append(request)

        def prove(group: list[dict]) -> tuple[dict, dict[str, np.ndarray]]:
            request = {"models": group, "runtimes": list(runtimes)}
            return run_tool("prove", request, frames, timeout_s=PROVE_TIMEOUT_S_PER_MODEL * max(1, len(group)))

        with ThreadPoolExecutor(max_workers=len(groups)) as pool:
            answers = list(pool.map(prove, groups))
    return _proof(expected, answers, runtimes)


def _prepared(
    specs: list, frames: dict[str, np.ndarray], folder: Path, first_seed: int, make: Callable[[Any, int], PolicyNetwork]
) -> tuple[dict[str, np.ndarray], list[dict]]:
    """racer's expected outputs per key, and the `prove` request of each model (its weights saved in `folder`)."""
    expected, requests = {}, []
    for index, spec in enumerate(specs):
        model = make(spec, first_seed + index)
        feeds = {name: torch.from_numpy(frames[name]) for name in model.input_names}
        with torch.inference_mode():
            expected[spec.key] = graph_output(model, feeds).numpy()
        weights = coach_tensors(ExportJob(model, None, 0))
        path = folder / f"{index}.safetensors"
        scope = policy_scope(model.config) + "/"
        save_file({name: value for name, value in weights.items() if name.startswith(scope)}, str(path))
        requests.append({"key": spec.key, "graph": coach_graph_spec(model.config), "weights_path": str(path)})
        del model, weights
    return expected, requests


def run_proofs_in_one_process(
    jobs: list[tuple[list, dict[str, np.ndarray]]],
    make: Callable[[Any, int], PolicyNetwork] = make_model,
    runtimes: tuple[str, ...] = RUNTIMES,
) -> list[dict]:
    """`run_proof` (one process, first seed 0) of each (specs, frames) job, all in one TensorFlow process, which
    starts once: frames of different shapes (stack sizes) go to different jobs."""
    with tempfile.TemporaryDirectory(prefix="racer-proof-") as folder:
        prepared, steps = [], []
        for index, (specs, frames) in enumerate(jobs):
            (Path(folder) / str(index)).mkdir()
            expected, requests = _prepared(specs, frames, Path(folder) / str(index), 0, make)
            prepared.append(expected)
            steps.append(("prove", {"models": requests, "runtimes": list(runtimes)}, frames))
        timeout_s = PROVE_TIMEOUT_S_PER_MODEL * max(1, sum(len(specs) for specs, _ in jobs))
        answers = run_tools(steps, timeout_s=timeout_s)
    return [_proof(expected, [answer], runtimes) for expected, answer in zip(prepared, answers, strict=True)]


def _proof(expected: dict[str, np.ndarray], answers: list[tuple[dict, dict]], runtimes: tuple[str, ...]) -> dict:
    outputs: dict[str, np.ndarray] = {}
    cpu_s: dict[str, dict[str, float]] = {}
    for result, produced in answers:
        outputs.update(produced)
        cpu_s.update(result["cpu_s"])
    return {"expected": expected, "outputs": outputs, "cpu_s": cpu_s, "runtimes": list(runtimes)}


def merge_proofs(proofs: list[dict]) -> dict:
    merged: dict = {"expected": {}, "outputs": {}, "cpu_s": {}, "runtimes": proofs[0]["runtimes"]}
    for proof in proofs:
        for part in ("expected", "outputs", "cpu_s"):
            merged[part].update(proof[part])
    return merged


def fp16_tolerance(expected: np.ndarray) -> float:
    """FP16_TOLERANCE, widened to FP16_ULPS fp16 steps at the output's largest magnitude."""
    step = float(np.spacing(np.float16(np.abs(expected).max())))
    return max(FP16_TOLERANCE, FP16_ULPS * step)


def summarize(proof: dict) -> dict:
    """Worst differences from racer per runtime, the fp16 greedy agreement, and whether the goals hold."""
    figures: dict = {"models": len(proof["expected"])}
    ok = True
    for runtime in proof["runtimes"]:
        differences = {
            key: float(np.abs(proof["outputs"][f"{key}|{runtime}"] - value).max())
            for key, value in proof["expected"].items()
        }
        worst_model = max(differences, key=differences.__getitem__)
        worst = differences[worst_model]
        tolerances = {key: fp16_tolerance(value) for key, value in proof["expected"].items()}
        fp16_excess = max(differences[key] / tolerances[key] for key in differences)
        same = min(
            (
                float(np.mean(proof["outputs"][f"{key}|{runtime}"].argmax(1) == value.argmax(1)))
                for key, value in proof["expected"].items()
                if key.endswith("discrete")
            ),
            default=1.0,
        )
        fp16 = runtime.endswith("fp16")
        ok = ok and (fp16_excess <= 1.0 and same >= FP16_SAME_ACTION if fp16 else worst <= FP32_TOLERANCE)
        cpu = sum(times.get(runtime, 0.0) for times in proof["cpu_s"].values())
        figures[runtime] = {
            "max_abs_diff": worst,
            "worst_model": worst_model,
            "max_diff_of_fp16_tolerance": round(fp16_excess, 3),
            "min_same_greedy_action": same,
            "cpu_s": round(cpu, 1),
        }
    figures["export_cpu_s"] = round(sum(times.get("export", 0.0) for times in proof["cpu_s"].values()), 1)
    figures["goals_met"] = ok
    return figures


@click.command("tf-proof")
@click.option("--frames", "frame_count", type=click.IntRange(min=1), default=100, show_default=True)
@click.option(
    "--algorithm",
    type=click.Choice(["all", "clipped_ppo", "sac"]),
    default="all",
    show_default=True,
    help="Only PPO's 48 models or SAC's 24 (the whole product takes long on 2 cores).",
)
@click.option(
    "--match",
    "matches",
    multiple=True,
    help="Only models whose key (NETWORK:SENSOR+SENSOR:discrete|continuous|sac) contains this text; repeatable.",
)
@click.option(
    "--models-per-process",
    type=click.IntRange(min=1),
    default=4,
    show_default=True,
    help="Models per group of TensorFlow processes; each group's figures are printed (stderr) when it ends.",
)
@click.option(
    "--processes",
    type=click.IntRange(min=1),
    default=1,
    show_default=True,
    help="TensorFlow processes side by side within a group (most conversion steps use one core; each process "
    "holds one model at a time).",
)
@click.option(
    "--examples",
    is_flag=True,
    help="Instead: docs/custom-networks.md's examples (WIDE_MIDDLEWARE, EXTRA_CONV_BATCHNORM, a two-frame stack of "
    "the shallow network; 6 models) on DeepRacer's Gazebo frames.",
)
def tf_proof_command(
    frame_count: int,
    algorithm: str,
    matches: tuple[str, ...],
    models_per_process: int,
    processes: int,
    examples: bool,
) -> None:
    """All 72 models (PPO discrete and continuous, SAC) through TensorFlow, OpenVINO and LiteRT (fp32, fp16) vs
    racer; one JSON line (and one per group of models on stderr as they finish)."""
    started = time.monotonic()
    if examples:
        figures = prove_examples(matches, processes)
        figures["wall_s"] = round(time.monotonic() - started, 1)
        print(json.dumps(figures))
        return
    specs = [
        spec
        for spec in all_specs()
        if (algorithm == "all" or spec.sac == (algorithm == "sac"))
        and (not matches or any(text in spec.key for text in matches))
    ]
    if not specs:
        raise click.UsageError("no model matches --algorithm and --match")
    print(f"rendering {frame_count} frames per sensor ...", file=sys.stderr, flush=True)
    frames = render_frames(frame_count)
    print(
        f"{len(specs)} models through TensorFlow, OpenVINO and LiteRT, {models_per_process} per TensorFlow process "
        "(an hour or more on 2 cores for all of them) ...",
        file=sys.stderr,
        flush=True,
    )
    proofs = []
    for start in range(0, len(specs), models_per_process):
        group = specs[start : start + models_per_process]
        proofs.append(run_proof(group, frames, first_seed=start, processes=processes))
        done = {"done": start + len(group), "of": len(specs), "keys": [spec.key for spec in group]}
        print(json.dumps({**done, **summarize(proofs[-1])}), file=sys.stderr, flush=True)
    figures = summarize(merge_proofs(proofs))
    figures["algorithm"] = algorithm
    figures["frames"] = frame_count
    figures["wall_s"] = round(time.monotonic() - started, 1)
    print(json.dumps(figures))


def prove_examples(matches: tuple[str, ...], processes: int = 1) -> dict:
    """docs/custom-networks.md's examples, each stack size's frames fed to its models, all in one TensorFlow process
    (`processes` > 1: `run_proof`'s processes per stack size); the figures of all of them."""
    from tests.model_io.tf_proof_examples import example_frames, example_specs, make_example

    specs = [spec for spec in example_specs() if not matches or any(text in spec.key for text in matches)]
    if not specs:
        raise click.UsageError("no example matches --match")
    jobs = []
    for stack_size in sorted({spec.stack_size for spec in specs}):
        group = [spec for spec in specs if spec.stack_size == stack_size]
        frames = example_frames(stack_size)
        print(f"{len(group)} examples on {len(next(iter(frames.values())))} Gazebo frames ...", file=sys.stderr)
        jobs.append((group, frames))
    if processes == 1:  # one TensorFlow start for every stack size
        proofs = run_proofs_in_one_process(jobs, make=make_example)
    else:
        proofs = [run_proof(group, frames, make=make_example, processes=processes) for group, frames in jobs]
    for (group, _), proof in zip(jobs, proofs, strict=True):
        print(json.dumps({"keys": [spec.key for spec in group], **summarize(proof)}), file=sys.stderr, flush=True)
    figures = summarize(merge_proofs(proofs))
    figures["examples"] = [spec.key for spec in specs]
    figures["frames"] = "gazebo_reinvent_episode"
    return figures


if __name__ == "__main__":
    tf_proof_command(prog_name="python -m tests.model_io.tf_proof")
