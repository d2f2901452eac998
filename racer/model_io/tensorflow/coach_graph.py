"""RL Coach's PPO and SAC networks rebuilt as TensorFlow graphs from a graph spec (coach_layout.graph_spec,
coach_sac_layout.sac_graph_spec), with RL Coach's variable and node names, and racer's weights loaded into them.

Runs only inside the TensorFlow process (`python -m racer.model_io.tensorflow.tool`, started by runner.py), which
switches TensorFlow to graph mode first; never import it in a racer process (see tool.py).
"""

from __future__ import annotations

import numpy as np
import tensorflow as tf


def _variable(name: str, shape: list[int], created: dict):
    variable = tf.compat.v1.Variable(tf.zeros(shape, dtype=tf.float32), name=name, dtype=tf.float32)
    created[name] = variable
    return variable


def _layer(x, scope: str, layer: dict, created: dict):
    """One conv or dense layer and what RL Coach puts after it, at inference: batch-norm with the running statistics,
    the activation; dropout is the identity (no node)."""
    prefix = f"{scope}/{layer['scope']}"
    kernel = _variable(f"{prefix}/kernel", layer["kernel"], created)
    bias = _variable(f"{prefix}/bias", [layer["kernel"][-1]], created)
    if layer["type"] == "conv":
        stride = int(layer["stride"])
        x = tf.nn.conv2d(x, kernel, strides=[1, stride, stride, 1], padding="VALID", name=f"{prefix}/Conv2D")
    else:
        if len(x.shape) > 2:
            x = tf.reshape(x, [-1, int(np.prod(x.shape[1:]))], name=f"{scope}/Flatten/flatten/Reshape")
        x = tf.linalg.matmul(x, kernel, name=f"{prefix}/MatMul")
    x = tf.nn.bias_add(x, bias, name=f"{prefix}/BiasAdd")
    batchnorm = layer.get("batchnorm")
    if batchnorm:
        where = f"{scope}/{batchnorm['scope']}"
        units = [int(batchnorm["units"])]
        gamma, beta, mean, variance = (
            _variable(f"{where}/{name}", units, created) for name in ("gamma", "beta", "moving_mean", "moving_variance")
        )
        x = tf.nn.batch_normalization(
            x, mean, variance, beta, gamma, float(batchnorm["epsilon"]), name=f"{where}/batchnorm"
        )
    activation = layer.get("activation", "relu")
    if activation == "relu":
        x = tf.nn.relu(x, name=f"{scope}/{layer['after']}_activation")
    elif activation == "tanh":
        x = tf.math.tanh(x, name=f"{scope}/{layer['after']}_activation")
    elif activation != "none":
        raise ValueError(f"{prefix}: unknown activation {activation!r}")
    return x


def _tower(spec: dict, network: str, placeholders: dict, created: dict, middleware_layers: list | None = None):
    features = []
    for embedder in spec["embedders"]:
        sensor = embedder["sensor"]
        scope = f"{network}/{sensor}"
        rescale = tf.constant(float(embedder["rescale"]), name=f"{scope}/truediv/y")  # RL Coach's input_rescaling
        x = tf.math.truediv(placeholders[sensor], rescale, name=f"{scope}/truediv")
        x = tf.math.subtract(x, tf.constant(0.0, name=f"{scope}/sub/y"), name=f"{scope}/sub")  # input_offset
        for layer in embedder["layers"]:
            x = _layer(x, scope, layer, created)
        if len(x.shape) > 2:
            x = tf.reshape(x, [-1, int(np.prod(x.shape[1:]))], name=f"{scope}/Flatten/flatten/Reshape")
        features.append(x)
    x = features[0] if len(features) == 1 else tf.concat(features, axis=-1, name=f"{network}/merger")
    middleware = f"{network}/{spec['middleware_scope']}"
    for layer in spec["middleware"] if middleware_layers is None else middleware_layers:
        x = _layer(x, middleware, layer, created)
    rescaler = tf.compat.v1.Variable(tf.constant(1.0), name=f"{network}/{spec['rescaler']}", dtype=tf.float32)
    created[f"{network}/{spec['rescaler']}"] = rescaler
    # RL Coach's head input: (1 - r) * stop_gradient(x) + r * x, which is x for every r.
    head_input = tf.math.add(
        tf.math.multiply(
            tf.math.subtract(tf.constant(1.0), rescaler, name=f"{network}/sub"),
            tf.stop_gradient(x, name=f"{network}/StopGradient"),
            name=f"{network}/mul",
        ),
        tf.math.multiply(rescaler, x, name=f"{network}/mul_1"),
        name=f"{network}/add",
    )
    return head_input


def _dense(x, scope: str, units: int, created: dict, relu: bool = False):
    kernel = _variable(f"{scope}/kernel", [int(x.shape[-1]), units], created)
    bias = _variable(f"{scope}/bias", [units], created)
    y = tf.nn.bias_add(tf.linalg.matmul(x, kernel, name=f"{scope}/MatMul"), bias, name=f"{scope}/BiasAdd")
    return tf.nn.relu(y, name=f"{scope}/Relu") if relu else y


def _placeholders(spec: dict, network: str) -> dict:
    return {
        embedder["sensor"]: tf.compat.v1.placeholder(
            tf.float32, [None, *embedder["shape"]], name=f"{network}/{embedder['sensor']}/{embedder['sensor']}"
        )
        for embedder in spec["embedders"]
    }


def build_sac_graph(spec: dict, with_critics: bool) -> tuple[tf.Graph, dict, dict, dict]:
    """RL Coach's SAC networks (policy; Q and V too if asked), each with its own placeholders as in RL Coach."""
    graph = tf.Graph()
    created: dict = {}
    outputs = {}
    with graph.as_default():
        policy = spec["policy_network"]
        placeholders = _placeholders(spec, policy)
        features = _tower(spec, policy, placeholders, created)
        head = f"{policy}/sac_policy_head_0"
        hidden = _dense(features, f"{head}/dense", spec["hidden_units"], created, relu=True)
        mean = _dense(hidden, f"{head}/policy_mean", spec["num_actions"], created)
        outputs["policy"] = tf.identity(mean, name=f"{head}/policy")  # the mean before tanh, as DeepRacer's
        low, high = spec["log_std_range"]
        log_std = _dense(hidden, f"{head}/dense_1", spec["num_actions"], created)
        outputs["log_std"] = tf.clip_by_value(log_std, low, high, name=f"{head}/policy_log_std")
        if with_critics:
            q_network = spec["q_network"]
            q_features = _tower(spec, q_network, _placeholders(spec, q_network), created, middleware_layers=[])
            actions = tf.compat.v1.placeholder(
                tf.float32, [None, spec["num_actions"]], name=f"{q_network}/q_values_head_0/action"
            )
            for twin in ("q1", "q2"):
                scope = f"{q_network}/q_values_head_0/{twin}_head"
                x = tf.concat([q_features, actions], -1, name=f"{scope}/concat")
                x = _dense(x, f"{scope}/dense", spec["hidden_units"], created, relu=True)
                x = _dense(x, f"{scope}/dense_1", spec["hidden_units"], created, relu=True)
                outputs[twin] = _dense(x, f"{scope}/{twin}_output", 1, created)
            v_network = spec["v_network"]
            v_features = _tower(spec, v_network, _placeholders(spec, v_network), created)
            outputs["value"] = _dense(v_features, f"{v_network}/v_values_head_0/output", 1, created)
    return graph, placeholders, created, outputs


def build_graph(spec: dict, with_value: bool) -> tuple[tf.Graph, dict, dict, dict]:
    """RL Coach's two towers (value only if asked). Returns graph, placeholders, variables by name, outputs."""
    if spec.get("algorithm") == "sac":
        return build_sac_graph(spec, with_critics=with_value)
    graph = tf.Graph()
    created: dict = {}
    outputs = {}
    with graph.as_default():
        placeholders = {
            embedder["sensor"]: tf.compat.v1.placeholder(
                tf.float32, [None, *embedder["shape"]], name=spec["input_nodes"][embedder["sensor"]]
            )
            for embedder in spec["embedders"]
        }
        if with_value:
            value_input = _tower(spec, spec["value_network"], placeholders, created)
            head = f"{spec['value_network']}/v_values_head_0/output"
            kernel = _variable(f"{head}/kernel", [int(value_input.shape[-1]), 1], created)
            bias = _variable(f"{head}/bias", [1], created)
            outputs["value"] = tf.nn.bias_add(
                tf.linalg.matmul(value_input, kernel, name=f"{head}/MatMul"), bias, name=f"{head}/BiasAdd"
            )
        policy_input = _tower(spec, spec["policy_network"], placeholders, created)
        head_scope = f"{spec['policy_network']}/ppo_head_0"
        fc = f"{head_scope}/policy_mean" if spec["continuous"] else f"{head_scope}/policy_fc"
        kernel = _variable(f"{fc}/kernel", [int(policy_input.shape[-1]), spec["num_actions"]], created)
        bias = _variable(f"{fc}/bias", [spec["num_actions"]], created)
        logits = tf.nn.bias_add(tf.linalg.matmul(policy_input, kernel, name=f"{fc}/MatMul"), bias, name=f"{fc}/BiasAdd")
        if spec["continuous"]:
            outputs["policy"] = tf.identity(logits, name=f"{head_scope}/policy")
            _variable(f"{head_scope}/policy_log_std", [1, spec["num_actions"]], created)
        else:
            outputs["policy"] = tf.nn.softmax(logits, name=f"{head_scope}/policy")
    return graph, placeholders, created, outputs


def load_weights(session, variables: dict, tensors: dict, default_rescaler: bool = False) -> None:
    if default_rescaler:  # the policy-only export does not send the log-std or rescaler: they are not on its path
        tensors = {
            **{
                name: np.zeros(variable.shape.as_list(), np.float32)
                for name, variable in variables.items()
                if name.endswith("policy_log_std")
            },
            **{name: np.ones((), np.float32) for name in variables if name.endswith("_rescalers")},
            **tensors,
        }
    missing = sorted(set(variables) - set(tensors))
    if missing:
        raise KeyError(f"no weights for {', '.join(missing)}")
    session.run([variable.initializer for variable in variables.values()])
    for name, variable in variables.items():
        variable.load(np.reshape(tensors[name], variable.shape.as_list()), session)  # safetensors keeps no 0-d
