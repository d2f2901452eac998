"""RL Coach's graph for one racer network: variable names, shapes and how each maps onto racer's weights.

DeepRacer's clipped-PPO graph (SimApp + RL Coach, read from a real checkpoint's `.index` and `.meta`) holds two
towers under `main_level/agent/main/online/`: `network_0` (value) and `network_1` (policy). Each tower has one
embedder per sensor (scope = sensor name, inputs in sorted order, concatenated as `merger`), the middleware
`middleware_fc_embedder`, a `gradients_from_head_0-0_rescalers` scalar and its head (`v_values_head_0/output`,
`ppo_head_0/policy_fc` (discrete) or `ppo_head_0/policy_mean` + `policy_log_std` (continuous)). Layer scopes count
the activation layers RL Coach inserts after each layer, so convolutions are `Conv2d_0`, `Conv2d_2`, ... and the
dense layers after them go on counting (`Dense_6` after three convolutions). The input placeholders live in
`network_0/<SENSOR>/<SENSOR>` and both towers read them.

Everything here is plain data (JSON-able) so that the TensorFlow side (`tool.py`, run in its own process) needs
neither torch nor racer's network code.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from racer.model_io.tensorflow.coach_layers import BATCHNORM_VARIABLES, coach_layers
from racer.shared.policy.networks import LOG_STD_MAX, LOG_STD_MIN, PIXEL_SCALE, PolicyConfig

__all__ = [
    "AGENT_SCOPE",
    "CoachVariable",
    "INPUT_NODE_FORMAT",
    "POLICY_OUTPUT_NODE",
    "POLICY_NETWORK",
    "VALUE_NETWORK",
    "coach_tensors_from_racer",
    "state_for_variables",
    "tensors_for_variables",
    "coach_variables",
    "graph_spec",
    "input_node",
    "racer_state_from_coach",
    "to_coach",
    "to_racer",
    "tower_layers",
    "tower_variables",
]

AGENT_SCOPE = "main_level/agent/main/online"
VALUE_NETWORK = f"{AGENT_SCOPE}/network_0"
POLICY_NETWORK = f"{AGENT_SCOPE}/network_1"
INPUT_NODE_FORMAT = VALUE_NETWORK + "/{sensor}/{sensor}"
POLICY_OUTPUT_NODE = f"{POLICY_NETWORK}/ppo_head_0/policy"
"""The SimApp's FROZEN_HEAD_OUTPUT_GRAPH_FORMAT_MAPPING for clipped PPO, agent `agent`."""
RESCALER = "gradients_from_head_0-0_rescalers"
MIDDLEWARE_SCOPE = "middleware_fc_embedder"


def input_node(sensor: str) -> str:
    return INPUT_NODE_FORMAT.format(sensor=sensor)


@dataclass(frozen=True)
class CoachVariable:
    name: str
    """Full TensorFlow variable name, e.g. `main_level/agent/main/online/network_1/ppo_head_0/policy_fc/kernel`."""
    shape: tuple[int, ...]
    racer_key: str | None
    """The racer state_dict key holding the same numbers (None: the rescaler, which racer has no use for)."""
    layout: str
    """How racer's tensor becomes TensorFlow's: `conv` (O,I,kh,kw) -> (kh,kw,I,O), `dense` (out,in) -> (in,out),
    `same`, `row` ((n,) -> (1, n)) or `scalar` (the rescaler, value 1.0)."""


def tower_layers(config: PolicyConfig) -> list[dict]:
    """Per tower: the embedders (sorted sensor names) with their layers, then the middleware. Scope names as RL Coach
    (coach_layers.py). Any network racer builds: DeepRacer's three or your own, single or stacked frames.

    Which layers an input gets is racer's own choice (`PolicyConfig.embedder_layers`: STEREO_CAMERAS by its sensor
    name, never by its channel count, which a two-frame stack of one camera shares); the first convolution reads the
    input's channels as they are (C * stack_size)."""
    embedders = []
    for spec in config.inputs:
        convs, dense = config.embedder_layers(spec)
        if spec.kind == "camera":
            layers, shape = coach_layers(convs, "convs", spec.shape)
            more, shape = coach_layers(dense, "dense", shape, first_index=len(convs))
            layers += more
            rescale = PIXEL_SCALE
        else:
            layers, shape = coach_layers(dense, "dense", spec.shape)
            rescale = 1.0
        embedders.append(
            {
                "sensor": spec.name,
                "shape": list(spec.shape),
                "rescale": rescale,
                "layers": layers,
                "features": int(np.prod(shape)),
            }
        )
    merged = sum(embedder["features"] for embedder in embedders)
    middleware, shape = coach_layers(config.middleware_layers, "middleware", (merged,))
    return [*embedders, {"middleware": middleware, "features": int(shape[0])}]


def coach_variables(config: PolicyConfig, include_value: bool = True) -> list[CoachVariable]:
    """Every variable RL Coach's saver writes for this network, in the SimApp's names and shapes."""
    *embedders, middleware = tower_layers(config)
    variables: list[CoachVariable] = []
    towers = [("policy_tower", POLICY_NETWORK)]
    if include_value:
        towers.insert(0, ("value_tower", VALUE_NETWORK))
    for tower, scope in towers:
        variables += tower_variables(tower, scope, embedders, middleware["middleware"])
        features = middleware["features"]
        if tower == "value_tower":
            head = f"{scope}/v_values_head_0/output"
            variables.append(CoachVariable(f"{head}/kernel", (features, 1), "value_head.weight", "dense"))
            variables.append(CoachVariable(f"{head}/bias", (1,), "value_head.bias", "same"))
        else:
            fc = "policy_mean" if config.is_continuous else "policy_fc"
            head = f"{scope}/ppo_head_0/{fc}"
            variables.append(
                CoachVariable(f"{head}/kernel", (features, config.num_actions), "policy_head.weight", "dense")
            )
            variables.append(CoachVariable(f"{head}/bias", (config.num_actions,), "policy_head.bias", "same"))
            if config.is_continuous:
                variables.append(
                    CoachVariable(f"{scope}/ppo_head_0/policy_log_std", (1, config.num_actions), "log_std", "row")
                )
    return variables


def tower_variables(tower: str, scope: str, embedders: list[dict], middleware: list[dict]) -> list[CoachVariable]:
    """One RL Coach network's embedders, middleware and gradient rescaler; `tower` is racer's Tower attribute."""
    variables = []
    for embedder in embedders:
        for layer in embedder["layers"]:
            variables += _layer_variables(
                layer, f"{scope}/{embedder['sensor']}", f"{tower}.embedders.{embedder['sensor']}"
            )
    for layer in middleware:
        variables += _layer_variables(layer, f"{scope}/{MIDDLEWARE_SCOPE}", tower)
    variables.append(CoachVariable(f"{scope}/{RESCALER}", (), None, "scalar"))
    return variables


def _layer_variables(layer: dict, scope: str, racer_prefix: str) -> list[CoachVariable]:
    """A conv or dense layer's kernel and bias, and its batch-norm's four vectors when it has one."""
    prefix = f"{scope}/{layer['scope']}"
    key = f"{racer_prefix}.{layer['racer']}"
    variables = [
        CoachVariable(f"{prefix}/kernel", tuple(layer["kernel"]), f"{key}.weight", layer["type"]),
        CoachVariable(f"{prefix}/bias", (layer["kernel"][-1],), f"{key}.bias", "same"),
    ]
    batchnorm = layer.get("batchnorm")
    if batchnorm:
        for coach, racer in BATCHNORM_VARIABLES:
            variables.append(
                CoachVariable(
                    f"{scope}/{batchnorm['scope']}/{coach}",
                    (batchnorm["units"],),
                    f"{racer_prefix}.{batchnorm['racer']}.{racer}",
                    "same",
                )
            )
    return variables


def to_coach(array: np.ndarray, layout: str) -> np.ndarray:
    if layout == "conv":
        return np.ascontiguousarray(array.transpose(2, 3, 1, 0))
    if layout == "dense":
        return np.ascontiguousarray(array.T)
    if layout == "row":
        return array.reshape(1, -1)
    return array


def to_racer(array: np.ndarray, layout: str) -> np.ndarray:
    if layout == "conv":
        return np.ascontiguousarray(array.transpose(3, 2, 0, 1))
    if layout == "dense":
        return np.ascontiguousarray(array.T)
    if layout == "row":
        return array.reshape(-1)
    return array


def coach_tensors_from_racer(config: PolicyConfig, state: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    """racer weights (state_dict as float32 numpy arrays) -> RL Coach's variables, rescalers at 1.0."""
    return tensors_for_variables(coach_variables(config), state)


def tensors_for_variables(variables: list[CoachVariable], state: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Each RL Coach variable from its racer tensor in TensorFlow's layout (rescalers, which racer lacks, at 1.0)."""
    tensors = {}
    for variable in variables:
        if variable.racer_key is None:
            tensors[variable.name] = np.asarray(1.0, dtype=np.float32)
        else:
            tensors[variable.name] = to_coach(np.asarray(state[variable.racer_key], dtype=np.float32), variable.layout)
        if tensors[variable.name].shape != variable.shape:
            raise ValueError(
                f"{variable.racer_key} has shape {tensors[variable.name].shape} in TensorFlow's layout, "
                f"RL Coach's {variable.name} has {variable.shape}"
            )
    return tensors


class CoachMismatchError(ValueError):
    """TensorFlow variables that racer's network for the given model_metadata.json cannot take, listed one by one."""


def racer_state_from_coach(
    config: PolicyConfig, tensors: Mapping[str, np.ndarray], include_value: bool
) -> dict[str, np.ndarray]:
    """RL Coach's variables -> racer state_dict entries (policy tower and head; the value tower too if asked).

    Raises CoachMismatchError listing every missing variable, wrong shape and unexpected network variable, so the
    user learns exactly which part of the graph racer's networks cannot represent."""
    known = {variable.name for variable in coach_variables(config, include_value=True)}
    scopes = (POLICY_NETWORK + "/", VALUE_NETWORK + "/") if include_value else (POLICY_NETWORK + "/",)
    return state_for_variables(
        coach_variables(config, include_value=include_value), known, scopes, tensors, config.neural_network
    )


def state_for_variables(
    expected: list[CoachVariable],
    known: set[str],
    scopes: tuple[str, ...],
    tensors: Mapping[str, np.ndarray],
    network_label: str,
) -> dict[str, np.ndarray]:
    """The racer tensors of `expected`; CoachMismatchError lists every missing or mis-shaped variable and every
    variable under `scopes` that is not in `known` (a layer racer's network does not have)."""
    problems = []
    state = {}
    for variable in expected:
        if variable.name not in tensors:
            problems.append(f"missing {variable.name} {list(variable.shape)}")
            continue
        array = np.asarray(tensors[variable.name])
        if variable.shape == () and array.size == 1:  # a scalar (safetensors stores it as shape [1])
            array = array.reshape(())
        if tuple(array.shape) != variable.shape:
            problems.append(
                f"{variable.name} has shape {list(array.shape)}, racer's network needs {list(variable.shape)}"
            )
            continue
        if variable.racer_key is not None:
            state[variable.racer_key] = to_racer(array.astype(np.float32), variable.layout)
    extra = sorted(name for name in tensors if name.startswith(scopes) and name not in known)
    problems += [
        f"unexpected {name} {list(np.shape(tensors[name]))} (no such layer in racer's {network_label} for these sensors)"
        for name in extra
    ]
    if problems:
        raise CoachMismatchError("; ".join(problems))
    return state


def graph_spec(config: PolicyConfig) -> dict:
    """What tool.py needs to build the graph: inputs, embedder layers, middleware, head. JSON-able."""
    *embedders, middleware = tower_layers(config)
    return {
        "value_network": VALUE_NETWORK,
        "policy_network": POLICY_NETWORK,
        "rescaler": RESCALER,
        "middleware_scope": MIDDLEWARE_SCOPE,
        "embedders": [{key: value for key, value in embedder.items() if key != "features"} for embedder in embedders],
        "middleware": middleware["middleware"],
        "continuous": config.is_continuous,
        "num_actions": config.num_actions,
        "log_std_range": [LOG_STD_MIN, LOG_STD_MAX],
        "output_node": POLICY_OUTPUT_NODE,
        "input_nodes": {embedder["sensor"]: input_node(embedder["sensor"]) for embedder in embedders},
    }
