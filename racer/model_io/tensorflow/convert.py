"""racer network <-> DeepRacer's TensorFlow files (frozen graph `model_<N>.pb`, checkpoint `<N>_Step-<M>.ckpt.*`).

Every TensorFlow step runs in its own process (runner.py); this module only moves numpy arrays and files.
"""

from __future__ import annotations

import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from racer.model_io.tensorflow.coach_layers import BATCHNORM_EPSILON
from racer.model_io.tensorflow.coach_layout import (
    POLICY_NETWORK,
    POLICY_OUTPUT_NODE,
    coach_tensors_from_racer,
    graph_spec,
    racer_state_from_coach,
)
from racer.model_io.tensorflow.coach_sac_layout import (
    SAC_POLICY_NETWORK,
    SAC_POLICY_OUTPUT_NODE,
    SAC_Q_NETWORK,
    sac_coach_tensors_from_racer,
    sac_graph_spec,
    sac_racer_state_from_coach,
)
from racer.model_io.tensorflow.errors import UnsupportedGraphError
from racer.model_io.tensorflow.runner import run_tool
from racer.shared.deepracer.model_metadata import ContinuousActionSpace
from racer.shared.policy.factory import PolicyNetwork, build_network
from racer.shared.policy.networks import PIXEL_SCALE, PolicyConfig
from racer.shared.policy.sac_networks import SACNetworks

__all__ = [
    "ExportJob",
    "ImportedNetwork",
    "TF_CHECKPOINT_SUFFIXES",
    "UnsupportedGraphError",
    "network_from_frozen_graph",
    "network_from_tf_checkpoint",
    "tensorflow_files",
]

TF_CHECKPOINT_SUFFIXES = (".index", ".data-00000-of-00001", ".meta")
FROZEN_WEIGHT_SUFFIXES = ("/kernel", "/bias", "policy_log_std", "/gamma", "/beta", "/moving_mean", "/moving_variance")
"""A frozen graph's constants that are racer weights (batch-norm's four vectors too, for your own network)."""


@dataclass(frozen=True)
class ImportedNetwork:
    network: PolicyNetwork
    value_restored: bool
    """False for a frozen graph: it holds the policy only, so the value network (SAC: Q and V) starts fresh."""
    notes: tuple[str, ...]


def _racer_arrays(network: PolicyNetwork) -> dict[str, np.ndarray]:
    return {key: value.detach().float().contiguous().cpu().numpy() for key, value in network.state_dict().items()}


@dataclass(frozen=True)
class ExportJob:
    network: PolicyNetwork
    checkpoint_name: str | None
    """Write the TensorFlow checkpoint `<checkpoint_name>.index/.data-00000-of-00001/.meta` (None: don't)."""
    number: int | None
    """Write the frozen graph `model_<number>.pb` (None: don't)."""
    action_space: ContinuousActionSpace | None = None
    """SAC: the metadata's continuous action space, which DeepRacer's Q networks read in degrees and m/s (needed
    for the checkpoint)."""


def policy_scope(config: PolicyConfig) -> str:
    """The network the frozen graph holds: PPO's network_1, SAC's policy network."""
    return SAC_POLICY_NETWORK if config.training_algorithm == "sac" else POLICY_NETWORK


def output_node(config: PolicyConfig) -> str:
    return SAC_POLICY_OUTPUT_NODE if config.training_algorithm == "sac" else POLICY_OUTPUT_NODE


def coach_graph_spec(config: PolicyConfig) -> dict:
    return sac_graph_spec(config) if config.training_algorithm == "sac" else graph_spec(config)


def coach_tensors(job: ExportJob) -> dict[str, np.ndarray]:
    """The job's network as RL Coach's variables (all of them; the caller keeps the policy's for a frozen graph)."""
    config = job.network.config
    if config.training_algorithm != "sac":
        return coach_tensors_from_racer(config, _racer_arrays(job.network))
    if job.checkpoint_name is not None and job.action_space is None:
        raise ValueError("a SAC checkpoint needs the model's continuous action space (its Q networks read it)")
    return sac_coach_tensors_from_racer(config, _racer_arrays(job.network), job.action_space)


def tensorflow_files(jobs: list[ExportJob]) -> list[dict[str, bytes]]:
    """For each job, its TensorFlow files as file name -> bytes; all jobs in one TensorFlow process."""
    arrays: dict[str, np.ndarray] = {}
    with tempfile.TemporaryDirectory(prefix="racer-tf-export-") as folder:
        work = Path(folder)
        requests = []
        for index, job in enumerate(jobs):
            key = str(index)
            tensors = coach_tensors(job)
            if job.checkpoint_name is None:  # the frozen graph holds the policy network only
                scope = policy_scope(job.network.config) + "/"
                tensors = {name: value for name, value in tensors.items() if name.startswith(scope)}
            arrays.update({f"{key}|{name}": value for name, value in tensors.items()})
            request: dict = {"key": key, "graph": coach_graph_spec(job.network.config)}
            (work / key).mkdir()
            if job.number is not None:
                request["frozen_path"] = str(work / key / f"model_{job.number}.pb")
            if job.checkpoint_name is not None:
                request["checkpoint_prefix"] = str(work / key / job.checkpoint_name)
            requests.append(request)
        run_tool("export", {"jobs": requests}, arrays)
        outputs = []
        for index, job in enumerate(jobs):
            files = {}
            if job.number is not None:
                files[f"model_{job.number}.pb"] = (work / str(index) / f"model_{job.number}.pb").read_bytes()
            if job.checkpoint_name is not None:
                for suffix in TF_CHECKPOINT_SUFFIXES:
                    files[job.checkpoint_name + suffix] = (
                        work / str(index) / (job.checkpoint_name + suffix)
                    ).read_bytes()
            outputs.append(files)
    return outputs


def _network_with(config: PolicyConfig, state: dict[str, np.ndarray]) -> PolicyNetwork:
    network = build_network(config)
    current = network.state_dict()
    merged = dict(current)
    for key, value in state.items():
        merged[key] = torch.from_numpy(np.ascontiguousarray(value)).to(current[key].dtype)
    network.load_state_dict(merged)
    if isinstance(network, SACNetworks):
        network.sync_target()  # RL Coach never saves the target V; it copies V into it at the start too
    return network.eval()


def network_from_tf_checkpoint(
    checkpoint_prefix: Path, config: PolicyConfig, action_space: ContinuousActionSpace | None = None
) -> ImportedNetwork:
    """A DeepRacer (RL Coach) TensorFlow checkpoint -> racer network; value network restored when it is there.
    SAC (`action_space`: the metadata's continuous space): policy, Q and V restored when the checkpoint has them."""
    result, tensors = run_tool("read_checkpoint", {"checkpoint_prefix": str(checkpoint_prefix)})
    if config.training_algorithm == "sac":
        return _sac_from_checkpoint(checkpoint_prefix, config, result["variables"], tensors, action_space)
    _refuse_foreign(result["variables"], config)
    has_value = any(
        name.startswith("main_level/agent/main/online/network_0/") and "v_values_head_0" in name
        for name in result["variables"]
    )
    try:
        state = racer_state_from_coach(config, tensors, include_value=has_value)
    except ValueError as error:
        raise UnsupportedGraphError(f"{checkpoint_prefix}: {error}") from None
    notes = () if has_value else ("the checkpoint has no value network (network_0); racer starts it fresh",)
    return ImportedNetwork(_network_with(config, state), has_value, notes)


def _sac_from_checkpoint(
    checkpoint_prefix: Path,
    config: PolicyConfig,
    variables: dict,
    tensors: dict,
    action_space: ContinuousActionSpace | None,
) -> ImportedNetwork:
    names = list(variables)
    if not any(name.startswith(SAC_POLICY_NETWORK + "/") for name in names):
        what = "a clipped-PPO model" if any("/agent/main/" in name for name in names) else "not a SAC model"
        raise UnsupportedGraphError(
            f"{checkpoint_prefix}: model_metadata.json says SAC, but the checkpoint is {what} "
            f"(no variable under {SAC_POLICY_NETWORK}/; first: {', '.join(names[:3]) or 'none'})"
        )
    has_critics = any(name.startswith(SAC_Q_NETWORK + "/") for name in names)
    if has_critics and action_space is None:
        raise ValueError("converting a SAC checkpoint's Q networks needs the model's continuous action space")
    try:
        state = sac_racer_state_from_coach(config, tensors, include_critics=has_critics, action_space=action_space)
    except ValueError as error:
        raise UnsupportedGraphError(f"{checkpoint_prefix}: {error}") from None
    notes = () if has_critics else ("the checkpoint has no Q and V networks; racer starts them fresh",)
    return ImportedNetwork(_network_with(config, state), has_critics, notes)


def _refuse_foreign(variables: dict, config: PolicyConfig) -> None:
    names = list(variables)
    if any("/agent/policy/" in name or "sac_" in name for name in names):
        raise UnsupportedGraphError(
            "this is a SAC model (variables under main_level/agent/policy/...), but model_metadata.json's "
            f"training_algorithm is {config.training_algorithm}: set it to sac"
        )
    if not any(name.startswith("main_level/agent/main/online/network_1/") for name in names):
        sample = ", ".join(names[:5]) or "none"
        raise UnsupportedGraphError(
            f"no RL Coach PPO policy network (main_level/agent/main/online/network_1/...) "
            f"among the variables (first: {sample})"
        )


def network_from_frozen_graph(frozen_path: Path, config: PolicyConfig) -> ImportedNetwork:
    """A DeepRacer frozen graph (`model_<N>.pb` or the car's `agent/model.pb`) -> racer network.

    The graph holds the policy only: the value network starts fresh (say so to the user)."""
    result, tensors = run_tool(
        "read_frozen",
        {
            "frozen_path": str(frozen_path),
            "output_nodes": [POLICY_OUTPUT_NODE, SAC_POLICY_OUTPUT_NODE],
        },
    )
    output = result["output_node"]
    sac = config.training_algorithm == "sac"
    if output is None:
        raise UnsupportedGraphError(
            f"{frozen_path}: no node {output_node(config)} (the SimApp's {'SAC' if sac else 'PPO'} output); "
            f"nodes include {', '.join(result.get('node_names_sample', []))}"
        )
    if output != output_node(config):
        raise UnsupportedGraphError(
            f"{frozen_path}: the graph's output is {output} ({'clipped PPO' if sac else 'SAC'}), but "
            f"model_metadata.json's training_algorithm is {config.training_algorithm}"
        )
    if result["unsupported_ops"]:
        described = "; ".join(
            f"{op} at {', '.join(names[:3])}" for op, names in sorted(result["unsupported_ops"].items())
        )
        raise UnsupportedGraphError(f"{frozen_path}: the graph has layers racer's networks do not have ({described})")
    expected_output_op = "Identity" if config.is_continuous else "Softmax"
    scope = policy_scope(config)
    if result["output_op"] != expected_output_op:
        raise UnsupportedGraphError(
            f"{frozen_path}: the output is a {result['output_op']} op; model_metadata.json's "
            f"{config.action_space_type} action space needs {expected_output_op}"
        )
    input_scope = SAC_POLICY_NETWORK if sac else "main_level/agent/main/online/network_0"
    wanted_inputs = {f"{input_scope}/{spec.name}/{spec.name}": [-1, *spec.shape] for spec in config.inputs}
    if set(result["placeholders"]) != set(wanted_inputs):
        raise UnsupportedGraphError(
            f"{frozen_path}: inputs {sorted(result['placeholders'])}, but model_metadata.json's "
            f"sensors need {sorted(wanted_inputs)}"
        )
    for name, shape in result["placeholders"].items():
        if shape and shape[1:] != wanted_inputs[name][1:]:
            wanted = wanted_inputs[name]
            hint = (
                f" (stack_size {config.stack_size}); a graph of stacked frames imports with the model's "
                "hyperparameters.json, which says its stack_size"
                if len(shape) == 4 and shape[1:3] == wanted[1:3] and shape[3] != wanted[3]
                else ""
            )
            raise UnsupportedGraphError(f"{frozen_path}: input {name} has shape {shape}, racer needs {wanted}{hint}")
    scalars = result.get("scalars", {})
    for spec in config.inputs:  # RL Coach divides camera pixels by 255 inside the graph, lidar values by 1
        wanted_scale = PIXEL_SCALE if spec.kind == "camera" else 1.0
        scale = scalars.get(f"{scope}/{spec.name}/truediv/y", wanted_scale)
        if scale != wanted_scale:
            raise UnsupportedGraphError(
                f"{frozen_path}: input {spec.name} is divided by {scale} inside the graph; "
                f"racer's network divides it by {wanted_scale}"
            )
    _check_batchnorm_epsilon(frozen_path, scalars)
    weights = {name: value for name, value in tensors.items() if name.endswith(FROZEN_WEIGHT_SUFFIXES)}
    if sac:
        return _sac_from_frozen(frozen_path, config, weights)
    if config.is_continuous:
        weights.setdefault(
            "main_level/agent/main/online/network_1/ppo_head_0/policy_log_std",
            np.zeros((1, config.num_actions), dtype=np.float32),
        )
    weights["main_level/agent/main/online/network_1/gradients_from_head_0-0_rescalers"] = np.asarray(1.0, np.float32)
    try:
        state = racer_state_from_coach(config, weights, include_value=False)
    except ValueError as error:
        raise UnsupportedGraphError(f"{frozen_path}: {error}") from None
    notes = [
        "a frozen graph holds the policy only: the value network starts fresh (its first iterations of "
        "training learn it; expect a short dip)"
    ]
    if config.is_continuous:
        notes.append("a frozen graph has no policy log-std: racer starts it at 0 (std 1.0), RL Coach's initial value")
    return ImportedNetwork(_network_with(config, state), False, tuple(notes))


def _check_batchnorm_epsilon(frozen_path: Path, scalars: dict[str, float]) -> None:
    """racer's batch-norm adds torch's epsilon to the variance; a graph with another one (RL Coach's own 1e-3)
    computes another function, which racer's network cannot take."""
    for name, value in sorted(scalars.items()):
        if name.endswith("_batchnorm/batchnorm/add/y") and not np.isclose(value, BATCHNORM_EPSILON, rtol=1e-3):
            raise UnsupportedGraphError(
                f"{frozen_path}: batch-norm {name.removesuffix('/batchnorm/add/y')} adds {value:g} to the variance; "
                f"racer's batch-norm adds {BATCHNORM_EPSILON:g}"
            )


def _sac_from_frozen(frozen_path: Path, config: PolicyConfig, weights: dict) -> ImportedNetwork:
    weights[f"{SAC_POLICY_NETWORK}/gradients_from_head_0-0_rescalers"] = np.asarray(1.0, np.float32)
    try:
        state = sac_racer_state_from_coach(
            config, weights, include_critics=False, action_space=None, include_log_std=False
        )
    except ValueError as error:
        raise UnsupportedGraphError(f"{frozen_path}: {error}") from None
    notes = (
        "a frozen graph holds the SAC policy's mean only: the Q and V networks start fresh (the first training "
        "steps learn them; expect a short dip)",
        "a frozen graph has no log-std layer (it is not on the path to the `policy` output): racer starts it "
        "freshly initialised, as a new SAC model's",
    )
    return ImportedNetwork(_network_with(config, state), False, notes)
