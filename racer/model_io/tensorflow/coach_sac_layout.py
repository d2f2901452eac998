"""RL Coach's SAC graph for one racer SACNetworks: variable names, shapes and how each maps onto racer's weights.

DeepRacer's SAC agent (SimApp `multi_agent_coach/agents/sac_agent.py`, `get_sac_params`) has three networks, each
a single tower `network_0` with its own copy of the embedders: `main_level/agent/policy/online/network_0` (embedders,
middleware, `sac_policy_head_0`), `.../q/online/network_0` (embedders, an empty middleware, `q_values_head_0` with
the twin heads `q1_head` / `q2_head`) and `.../v/online/network_0` (embedders, middleware, `v_values_head_0`). The
target V (`.../v/target/...`) is never saved: RL Coach's saver skips `/target` and syncs it from V at the start.

Head layers are unnamed `Dense` layers in RL Coach, so TensorFlow numbers them per scope: the policy head's
`dense` (256, ReLU), `policy_mean` and `dense_1` (log-std, clipped to [-20, 2]); each Q head's `dense`, `dense_1`
(256, ReLU) and `q1_output` / `q2_output`. Those are the names of SimApp checkpoints made with `tf.layers`; the
newer SimApp (Keras layers, numbered across the graph: `q1_head/dense_2`, ...) restores them by scope and shape.

The frozen graph's output `sac_policy_head_0/policy` is the Gaussian mean *before* the tanh squash (SimApp's
FROZEN_HEAD_OUTPUT_GRAPH_FORMAT_MAPPING); its inputs are the policy network's placeholders
`main_level/agent/policy/online/network_0/<SENSOR>/<SENSOR>`.

One unit conversion: racer's Q networks read the action in the network's [-1, 1] box, DeepRacer's read it in
degrees and m/s (`BoxActionSpace(low, high)`). The first Q layer is linear in the action, so its action columns and
bias are rescaled exactly on the way out and back (`action_space`), and both compute the same Q of the same action.
"""

from __future__ import annotations

import re
from collections.abc import Mapping

import numpy as np

from racer.model_io.tensorflow.coach_layout import (
    MIDDLEWARE_SCOPE,
    RESCALER,
    CoachVariable,
    state_for_variables,
    tensors_for_variables,
    tower_layers,
    tower_variables,
)
from racer.shared.deepracer.model_metadata import ContinuousActionSpace
from racer.shared.policy.networks import PolicyConfig
from racer.shared.policy.sac_networks import SAC_HIDDEN_UNITS, SAC_LOG_STD_MAX, SAC_LOG_STD_MIN

__all__ = [
    "SAC_POLICY_NETWORK",
    "SAC_POLICY_OUTPUT_NODE",
    "SAC_Q_NETWORK",
    "SAC_V_NETWORK",
    "sac_coach_tensors_from_racer",
    "sac_coach_variables",
    "sac_graph_spec",
    "sac_input_node",
    "sac_racer_state_from_coach",
    "keras_names_to_layer_names",
]

SAC_POLICY_NETWORK = "main_level/agent/policy/online/network_0"
SAC_Q_NETWORK = "main_level/agent/q/online/network_0"
SAC_V_NETWORK = "main_level/agent/v/online/network_0"
SAC_POLICY_OUTPUT_NODE = f"{SAC_POLICY_NETWORK}/sac_policy_head_0/policy"
"""The SimApp's FROZEN_HEAD_OUTPUT_GRAPH_FORMAT_MAPPING for SAC, agent `agent`."""
POLICY_HEAD = "sac_policy_head_0"
Q_HEAD = "q_values_head_0"


def sac_input_node(sensor: str) -> str:
    return f"{SAC_POLICY_NETWORK}/{sensor}/{sensor}"


def _dense(name: str, shape: tuple[int, int], racer: str) -> list[CoachVariable]:
    return [
        CoachVariable(f"{name}/kernel", shape, f"{racer}.weight", "dense"),
        CoachVariable(f"{name}/bias", (shape[1],), f"{racer}.bias", "same"),
    ]


def sac_coach_variables(config: PolicyConfig, include_critics: bool = True) -> list[CoachVariable]:
    """Every variable RL Coach's saver writes for this SAC model (policy; with the critics also Q and V)."""
    *embedders, middleware = tower_layers(config)
    actions = config.num_actions
    head = f"{SAC_POLICY_NETWORK}/{POLICY_HEAD}"
    variables = tower_variables("policy_tower", SAC_POLICY_NETWORK, embedders, middleware["middleware"])
    variables += _dense(f"{head}/dense", (middleware["features"], SAC_HIDDEN_UNITS), "policy_head.hidden")
    variables += _dense(f"{head}/policy_mean", (SAC_HIDDEN_UNITS, actions), "policy_head.mean")
    variables += _dense(f"{head}/dense_1", (SAC_HIDDEN_UNITS, actions), "policy_head.log_std")
    if not include_critics:
        return variables
    variables += tower_variables("q_tower", SAC_Q_NETWORK, embedders, [])
    q_features = sum(embedder["features"] for embedder in embedders)
    for twin in ("q1", "q2"):
        scope = f"{SAC_Q_NETWORK}/{Q_HEAD}/{twin}_head"
        variables += _dense(f"{scope}/dense", (q_features + actions, SAC_HIDDEN_UNITS), f"q_head.{twin}.0")
        variables += _dense(f"{scope}/dense_1", (SAC_HIDDEN_UNITS, SAC_HIDDEN_UNITS), f"q_head.{twin}.2")
        variables += _dense(f"{scope}/{twin}_output", (SAC_HIDDEN_UNITS, 1), f"q_head.{twin}.4")
    variables += tower_variables("value_tower", SAC_V_NETWORK, embedders, middleware["middleware"])
    variables += _dense(f"{SAC_V_NETWORK}/v_values_head_0/output", (middleware["features"], 1), "value_head")
    return variables


def _action_affine(space: ContinuousActionSpace) -> tuple[np.ndarray, np.ndarray]:
    """(scale, bias) with DeepRacer's action = scale * racer's action + bias, per dimension (steering, speed)."""
    low = np.array([space.steering_angle_low_deg, space.speed_low_mps], dtype=np.float64)
    high = np.array([space.steering_angle_high_deg, space.speed_high_mps], dtype=np.float64)
    return (high - low) / 2.0, (high + low) / 2.0


FIRST_Q_LAYERS = ("q_head.q1.0", "q_head.q2.0")


def sac_coach_tensors_from_racer(
    config: PolicyConfig, state: Mapping[str, np.ndarray], action_space: ContinuousActionSpace | None
) -> dict[str, np.ndarray]:
    """racer SAC weights (state_dict as numpy) -> RL Coach's variables. `action_space` (the metadata's) rescales the
    first Q layers to DeepRacer's action units; None leaves them in racer's (only for policy-only exports, which
    drop the Q network)."""
    state = dict(state)
    if action_space is not None:
        scale, bias = _action_affine(action_space)
        for layer in FIRST_Q_LAYERS:
            weight = np.asarray(state[f"{layer}.weight"], dtype=np.float64)
            action_columns = weight[:, -config.num_actions :]
            # racer: W_a a + b with a = (a_dr - bias) / scale  ->  DeepRacer: (W_a / scale) a_dr + b - W_a (bias / scale)
            converted = weight.copy()
            converted[:, -config.num_actions :] = action_columns / scale
            state[f"{layer}.weight"] = converted.astype(np.float32)
            state[f"{layer}.bias"] = (
                np.asarray(state[f"{layer}.bias"], dtype=np.float64) - action_columns @ (bias / scale)
            ).astype(np.float32)
    return tensors_for_variables(sac_coach_variables(config), state)


def sac_racer_state_from_coach(
    config: PolicyConfig,
    tensors: Mapping[str, np.ndarray],
    include_critics: bool,
    action_space: ContinuousActionSpace | None,
    include_log_std: bool = True,
) -> dict[str, np.ndarray]:
    """RL Coach's SAC variables -> racer state_dict entries (policy; Q and V too if asked). Raises CoachMismatchError
    naming every missing, mis-shaped or unexpected variable. A frozen graph has no log-std layer (`include_log_std`
    False): it is not on the path to the `policy` output."""
    tensors = keras_names_to_layer_names(tensors)
    expected = [
        variable
        for variable in sac_coach_variables(config, include_critics=include_critics)
        if include_log_std or not variable.name.startswith(f"{SAC_POLICY_NETWORK}/{POLICY_HEAD}/dense_1/")
    ]
    known = {variable.name for variable in sac_coach_variables(config, include_critics=True)}
    scopes = (SAC_POLICY_NETWORK + "/", SAC_Q_NETWORK + "/", SAC_V_NETWORK + "/")
    state = state_for_variables(expected, known, scopes, tensors, f"SAC {config.neural_network}")
    if include_critics and action_space is not None:
        scale, bias = _action_affine(action_space)
        for layer in FIRST_Q_LAYERS:
            weight = state[f"{layer}.weight"].astype(np.float64)
            action_columns = weight[:, -config.num_actions :]
            # the inverse of sac_coach_tensors_from_racer: W_a(racer) = W_a(DeepRacer) * scale
            state[f"{layer}.weight"] = np.concatenate(
                [weight[:, : -config.num_actions], action_columns * scale], axis=1
            ).astype(np.float32)
            state[f"{layer}.bias"] = (state[f"{layer}.bias"].astype(np.float64) + action_columns @ bias).astype(
                np.float32
            )
    return state


_UNNAMED_DENSE = re.compile(
    r"^(?P<scope>.+/(?:sac_policy_head_0|q1_head|q2_head))/dense(?:_(?P<n>\d+))?/(?P<part>kernel|bias)$"
)


def keras_names_to_layer_names(tensors: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The ROS 2 SimApp's Keras layers number unnamed Dense layers across the graph (`q1_head/dense_2`,
    `q2_head/dense_5`); `tf.layers` numbered them per scope (`dense`, `dense_1`), which racer writes. Within one
    head the numbers keep the order the layers were made in, so renumbering them per scope maps one onto the other
    (the SimApp's own restore matches them by scope and shape the same way)."""
    numbers: dict[str, set[int]] = {}
    for name in tensors:
        match = _UNNAMED_DENSE.match(name)
        if match:
            numbers.setdefault(match["scope"], set()).add(int(match["n"] or 0))
    renamed = {}
    for name, value in tensors.items():
        match = _UNNAMED_DENSE.match(name)
        if match:
            index = sorted(numbers[match["scope"]]).index(int(match["n"] or 0))
            name = f"{match['scope']}/dense{'_' + str(index) if index else ''}/{match['part']}"
        renamed[name] = value
    return renamed


def sac_graph_spec(config: PolicyConfig) -> dict:
    """What tool.py needs to build RL Coach's SAC graph. JSON-able."""
    *embedders, middleware = tower_layers(config)
    return {
        "algorithm": "sac",
        "policy_network": SAC_POLICY_NETWORK,
        "q_network": SAC_Q_NETWORK,
        "v_network": SAC_V_NETWORK,
        "rescaler": RESCALER,
        "middleware_scope": MIDDLEWARE_SCOPE,
        "embedders": [{key: value for key, value in embedder.items() if key != "features"} for embedder in embedders],
        "middleware": middleware["middleware"],
        "continuous": True,
        "num_actions": config.num_actions,
        "hidden_units": SAC_HIDDEN_UNITS,
        "log_std_range": [SAC_LOG_STD_MIN, SAC_LOG_STD_MAX],
        "output_node": SAC_POLICY_OUTPUT_NODE,
        "input_nodes": {embedder["sensor"]: sac_input_node(embedder["sensor"]) for embedder in embedders},
    }
