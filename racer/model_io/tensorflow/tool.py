"""The TensorFlow side of racer's model export and import; runs only as `python -m racer.model_io.tensorflow.tool`.

Never import this module in a racer process: `import tensorflow` in a process that has rendered with Mesa (EGL or
OSMesa) segfaults, and TensorFlow, OpenVINO and LiteRT are an optional extra. `runner.py` starts this module in a
fresh interpreter with a work folder holding `request.json` (the command and its arguments) and `arrays.safetensors`
(numpy arrays), and reads back `result.json` and `result.safetensors`.

Commands (request["command"]):
- `export`: build RL Coach's graph (PPO or SAC) from a graph spec (coach_layout.graph_spec,
  coach_sac_layout.sac_graph_spec) and weights keyed by RL Coach's
  variable names; write the frozen inference graph (`frozen_path`) and/or a TensorFlow checkpoint
  (`checkpoint_prefix` + `.index`, `.data-00000-of-00001`, `.meta`).
- `read_checkpoint`: every variable of a TensorFlow checkpoint (name, shape, values).
- `read_frozen`: the constants, placeholders and op types of a frozen graph's inference path.
- `run`: feed arrays through frozen graphs with TensorFlow and, optionally, through OpenVINO IR and LiteRT models
  converted from them (fp32 and fp16), for the proof that every runtime computes the same function.
- `prove`: `run` for many models given as graph spec + weights file each, one model in memory at a time.
- `restore_meta`: import a `.meta` graph (e.g. the SimApp's own) and restore a checkpoint into it with its saver;
  report missing or mismatched variables and the policy output for the given inputs.
"""

from __future__ import annotations

import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import tensorflow as tf  # runner.py starts this process with TF_CPP_MIN_LOG_LEVEL=2: errors only
from safetensors.numpy import load_file, save_file

tf.compat.v1.disable_eager_execution()
tf.compat.v1.disable_resource_variables()  # RL Coach's variables are VariableV2, as in DeepRacer's .meta

INFERENCE_OPS = frozenset(
    {
        "Placeholder",
        "Const",
        "Identity",
        "RealDiv",
        "Sub",
        "Conv2D",
        "BiasAdd",
        "Relu",
        "Shape",
        "StridedSlice",
        "Pack",
        "Reshape",
        "ConcatV2",
        "MatMul",
        "Mul",
        "Add",
        "AddV2",
        "StopGradient",
        "Softmax",
    }
)
"""Op types of RL Coach's PPO and SAC inference paths; any other op is a layer racer's networks do not have."""


# --------------------------------------------------------------------------------------------------------------------
# Graph building


def _variable(name: str, shape: list[int], created: dict):
    variable = tf.compat.v1.Variable(tf.zeros(shape, dtype=tf.float32), name=name, dtype=tf.float32)
    created[name] = variable
    return variable


def _tower(spec: dict, network: str, placeholders: dict, created: dict, middleware_layers: list | None = None):
    features = []
    for embedder in spec["embedders"]:
        sensor = embedder["sensor"]
        scope = f"{network}/{sensor}"
        rescale = tf.constant(float(embedder["rescale"]), name=f"{scope}/truediv/y")  # RL Coach's input_rescaling
        x = tf.math.truediv(placeholders[sensor], rescale, name=f"{scope}/truediv")
        x = tf.math.subtract(x, tf.constant(0.0, name=f"{scope}/sub/y"), name=f"{scope}/sub")  # input_offset
        for layer in embedder["layers"]:
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
            x = tf.nn.relu(
                x, name=f"{scope}/BatchnormActivationDropout_{int(layer['scope'].rsplit('_', 1)[1]) + 1}_activation"
            )
        if len(x.shape) > 2:
            x = tf.reshape(x, [-1, int(np.prod(x.shape[1:]))], name=f"{scope}/Flatten/flatten/Reshape")
        features.append(x)
    x = features[0] if len(features) == 1 else tf.concat(features, axis=-1, name=f"{network}/merger")
    middleware = f"{network}/{spec['middleware_scope']}"
    for layer in spec["middleware"] if middleware_layers is None else middleware_layers:
        prefix = f"{middleware}/{layer['scope']}"
        kernel = _variable(f"{prefix}/kernel", layer["kernel"], created)
        bias = _variable(f"{prefix}/bias", [layer["kernel"][-1]], created)
        x = tf.nn.bias_add(tf.linalg.matmul(x, kernel, name=f"{prefix}/MatMul"), bias, name=f"{prefix}/BiasAdd")
        x = tf.nn.relu(
            x, name=f"{middleware}/BatchnormActivationDropout_{int(layer['scope'].rsplit('_', 1)[1]) + 1}_activation"
        )
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


def _load_weights(session, variables: dict, tensors: dict, default_rescaler: bool = False) -> None:
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


def command_export(request: dict, arrays: dict) -> tuple[dict, dict]:
    """request["jobs"]: [{"key", "graph", "frozen_path"?, "checkpoint_prefix"?}]; arrays "<key>|<variable name>"."""
    results = {}
    for job in request["jobs"]:
        prefix = f"{job['key']}|"
        weights = {name.removeprefix(prefix): value for name, value in arrays.items() if name.startswith(prefix)}
        results[job["key"]] = _export_one(job, weights)
    return results, {}


def _export_one(request: dict, arrays: dict) -> dict:
    spec = request["graph"]
    result = {}
    if request.get("frozen_path"):
        graph, _, variables, _ = build_graph(spec, with_value=False)
        with tf.compat.v1.Session(graph=graph) as session:
            _load_weights(session, variables, arrays, default_rescaler=True)
            frozen = tf.compat.v1.graph_util.convert_variables_to_constants(
                session, graph.as_graph_def(), [spec["output_node"]]
            )
        Path(request["frozen_path"]).write_bytes(frozen.SerializeToString())
        result["frozen_nodes"] = len(frozen.node)
    if request.get("checkpoint_prefix"):
        graph, _, variables, _ = build_graph(spec, with_value=True)
        with graph.as_default(), tf.compat.v1.Session(graph=graph) as session:
            _load_weights(session, variables, arrays)
            saver = tf.compat.v1.train.Saver(var_list=variables, max_to_keep=None)
            saver.save(session, request["checkpoint_prefix"], write_meta_graph=True, write_state=False)
        result["checkpoint_variables"] = sorted(variables)
    return result


# --------------------------------------------------------------------------------------------------------------------
# Reading


def command_read_checkpoint(request: dict, arrays: dict) -> tuple[dict, dict]:
    reader = tf.train.load_checkpoint(request["checkpoint_prefix"])
    shapes = reader.get_variable_to_shape_map()
    dtypes = reader.get_variable_to_dtype_map()
    tensors = {}
    described = {}
    for name in sorted(shapes):
        described[name] = {"shape": list(shapes[name]), "dtype": dtypes[name].name}
        if request.get("values", True) and dtypes[name].is_floating:
            tensors[name] = np.ascontiguousarray(reader.get_tensor(name), dtype=np.float32)
    return {"variables": described}, tensors


def _graph_def(path: str):
    graph_def = tf.compat.v1.GraphDef()
    graph_def.ParseFromString(Path(path).read_bytes())
    return graph_def


def command_read_frozen(request: dict, arrays: dict) -> tuple[dict, dict]:
    graph_def = _graph_def(request["frozen_path"])
    nodes = {node.name: node for node in graph_def.node}
    outputs = [name for name in request["output_nodes"] if name in nodes]
    result: dict = {
        "output_node": outputs[0] if outputs else None,
        "placeholders": {},
        "unsupported_ops": {},
        "op_counts": {},
    }
    if not outputs:
        result["node_names_sample"] = sorted(nodes)[:20]
        return result, {}
    # Walk the inference path back from the output.
    seen: set[str] = set()
    stack = [outputs[0]]
    while stack:
        name = stack.pop().lstrip("^").split(":")[0]
        if name in seen or name not in nodes:
            continue
        seen.add(name)
        stack.extend(nodes[name].input)
    tensors = {}
    for name in sorted(seen):
        node = nodes[name]
        result["op_counts"][node.op] = result["op_counts"].get(node.op, 0) + 1
        if node.op not in INFERENCE_OPS:
            result["unsupported_ops"].setdefault(node.op, []).append(name)
        if node.op == "Placeholder":
            dims = node.attr["shape"].shape.dim
            result["placeholders"][name] = [int(dim.size) for dim in dims]
        if node.op == "Const" and node.attr["dtype"].type == tf.float32.as_datatype_enum:
            value = tf.make_ndarray(node.attr["value"].tensor)
            if name.endswith(("/kernel", "/bias", "_rescalers", "policy_log_std")) or value.size > 1:
                tensors[name] = np.ascontiguousarray(value, dtype=np.float32)
            elif value.size == 1:
                result.setdefault("scalars", {})[name] = float(value.reshape(-1)[0])
    result["output_op"] = nodes[outputs[0]].op
    return result, tensors


# --------------------------------------------------------------------------------------------------------------------
# Running: TensorFlow, OpenVINO, LiteRT


def _run_tensorflow(path: str, feeds: dict, output: str) -> np.ndarray:
    graph = tf.Graph()
    with graph.as_default():
        tf.compat.v1.import_graph_def(_graph_def(path), name="")
    with tf.compat.v1.Session(graph=graph) as session:
        return session.run(f"{output}:0", {f"{name}:0": value for name, value in feeds.items()})


def _run_openvino(path: str, feeds: dict, output: str, fp16: bool, work: Path, converted: dict) -> np.ndarray:
    """`converted` keeps the model OpenVINO's converter made from `path`: fp32 and fp16 IR are saved from one
    conversion, as the converter's fp16 compression is a save option."""
    import openvino as ov

    if path not in converted:
        # OpenVINO's TensorFlow front end names tensors `<node>:0`. The car converts with a batch of one.
        converted[path] = ov.convert_model(
            path, input=[(f"{name}:0", [1, *value.shape[1:]]) for name, value in feeds.items()], output=[f"{output}:0"]
        )
    model = converted[path]
    xml = work / f"openvino_{'fp16' if fp16 else 'fp32'}.xml"
    ov.save_model(model, str(xml), compress_to_fp16=fp16)
    core = ov.Core()
    compiled = core.compile_model(str(xml), "CPU", {"INFERENCE_PRECISION_HINT": "f32", "INFERENCE_NUM_THREADS": 1})
    request = compiled.create_infer_request()
    names = {port.get_any_name().split(":")[0]: port for port in compiled.inputs}
    rows = []
    count = next(iter(feeds.values())).shape[0]
    for row in range(count):
        request.infer({names[name]: value[row : row + 1] for name, value in feeds.items()})
        rows.append(np.array(request.get_output_tensor(0).data, copy=True)[0])
    return np.stack(rows)


def _run_litert(path: str, feeds: dict, output: str, fp16: bool) -> np.ndarray:
    from ai_edge_litert.interpreter import Interpreter

    converter = tf.compat.v1.lite.TFLiteConverter.from_frozen_graph(
        path,
        input_arrays=list(feeds),
        output_arrays=[output],
        input_shapes={name: [1, *value.shape[1:]] for name, value in feeds.items()},
    )
    if fp16:
        converter.optimizations = [tf.lite.Optimize.DEFAULT]
        converter.target_spec.supported_types = [tf.float16]
    interpreter = Interpreter(model_content=converter.convert(), num_threads=1)
    interpreter.allocate_tensors()
    by_name = {detail["name"]: detail["index"] for detail in interpreter.get_input_details()}
    output_index = interpreter.get_output_details()[0]["index"]
    rows = []
    count = next(iter(feeds.values())).shape[0]
    for row in range(count):
        for name, value in feeds.items():
            interpreter.set_tensor(by_name[name], value[row : row + 1])
        interpreter.invoke()
        rows.append(np.array(interpreter.get_tensor(output_index), copy=True)[0])
    return np.stack(rows)


def command_run(request: dict, arrays: dict) -> tuple[dict, dict]:
    """request["models"]: [{"key", "frozen_path", "inputs": [node names], "output"}]; arrays "<key>|<node>"."""
    outputs = {}
    cpu_s: dict[str, dict[str, float]] = {}
    runtimes = request.get("runtimes", ["tensorflow"])
    for model in request["models"]:
        feeds = {node: arrays[f"{model['key']}|{node}"] for node in model["inputs"]}
        converted: dict = {}
        with tempfile.TemporaryDirectory() as work:
            for runtime in runtimes:
                started = time.process_time()
                if runtime == "tensorflow":
                    value = _run_tensorflow(model["frozen_path"], feeds, model["output"])
                elif runtime in ("openvino_fp32", "openvino_fp16"):
                    value = _run_openvino(
                        model["frozen_path"], feeds, model["output"], runtime.endswith("16"), Path(work), converted
                    )
                elif runtime in ("litert_fp32", "litert_fp16"):
                    value = _run_litert(model["frozen_path"], feeds, model["output"], runtime.endswith("16"))
                else:
                    raise ValueError(f"unknown runtime {runtime!r}")
                outputs[f"{model['key']}|{runtime}"] = np.ascontiguousarray(value, dtype=np.float32)
                cpu_s.setdefault(model["key"], {})[runtime] = time.process_time() - started
    return {"runtimes": runtimes, "cpu_s": cpu_s}, outputs


def command_prove(request: dict, arrays: dict) -> tuple[dict, dict]:
    """For each model (graph spec + its own weights file): freeze its policy graph, then run it with every runtime.

    One model in memory at a time (a stereo DEEP policy network is 230 MB); arrays: frames keyed by sensor name."""
    outputs = {}
    cpu_s: dict[str, dict[str, float]] = {}
    for model in request["models"]:
        started = time.process_time()
        weights = load_file(model["weights_path"])
        with tempfile.TemporaryDirectory() as work:
            frozen = str(Path(work) / "model.pb")
            _export_one({"graph": model["graph"], "frozen_path": frozen}, weights)
            del weights
            export_s = time.process_time() - started
            feeds = {node: arrays[sensor] for sensor, node in model["graph"]["input_nodes"].items()}
            single = {
                "key": model["key"],
                "frozen_path": frozen,
                "inputs": list(feeds),
                "output": model["graph"]["output_node"],
            }
            ran, produced = command_run(
                {"models": [single], "runtimes": request["runtimes"]},
                {f"{model['key']}|{node}": value for node, value in feeds.items()},
            )
        outputs.update(produced)
        cpu_s[model["key"]] = {"export": export_s, **ran["cpu_s"][model["key"]]}
    return {"runtimes": request["runtimes"], "cpu_s": cpu_s}, outputs


def command_restore_meta(request: dict, arrays: dict) -> tuple[dict, dict]:
    """Import a .meta graph and restore `checkpoint_prefix` with its own saver, like RL Coach's restore."""
    graph = tf.Graph()
    with graph.as_default():
        saver = tf.compat.v1.train.import_meta_graph(request["meta_path"], clear_devices=True)
        reader = tf.train.load_checkpoint(request["checkpoint_prefix"])
        stored = reader.get_variable_to_shape_map()
        wanted = {variable.op.name: variable.shape.as_list() for variable in tf.compat.v1.global_variables()}
        missing = sorted(name for name in wanted if name not in stored and _saved_by(saver, name))
        mismatched = sorted(
            f"{name}: checkpoint {list(stored[name])}, graph {shape}"
            for name, shape in wanted.items()
            if name in stored and list(stored[name]) != shape
        )
        result = {"missing": missing, "mismatched": mismatched, "restored": False}
        tensors = {}
        if not missing and not mismatched:
            with tf.compat.v1.Session(graph=graph) as session:
                saver.restore(session, request["checkpoint_prefix"])
                result["restored"] = True
                feeds = {f"{name}:0": arrays[name] for name in request["inputs"]}
                tensors["policy"] = np.ascontiguousarray(session.run(f"{request['output']}:0", feeds), dtype=np.float32)
    return result, tensors


def _saved_by(saver, name: str) -> bool:
    """Whether the imported saver restores variable `name` (RL Coach's saver covers the network weights only)."""
    restore = saver.saver_def.restore_op_name.rsplit("/", 1)[0]
    graph = tf.compat.v1.get_default_graph()
    try:
        names = graph.get_tensor_by_name(f"{restore}/RestoreV2/tensor_names:0").op.get_attr("value")
    except KeyError:
        return True
    return name.encode() in set(tf.make_ndarray(names).tolist())


COMMANDS = {
    "export": command_export,
    "read_checkpoint": command_read_checkpoint,
    "read_frozen": command_read_frozen,
    "run": command_run,
    "prove": command_prove,
    "restore_meta": command_restore_meta,
}


def main(argv: list[str]) -> int:
    work = Path(argv[1])
    request = json.loads((work / "request.json").read_text())
    arrays_path = work / "arrays.safetensors"
    arrays = load_file(str(arrays_path)) if arrays_path.exists() else {}
    result, tensors = COMMANDS[request["command"]](request, arrays)
    save_file(tensors, str(work / "result.safetensors"))
    (work / "result.json").write_text(json.dumps(result))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
