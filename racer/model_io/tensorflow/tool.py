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
- `steps`: several of the commands above in this one process, one after another (`runner.run_tools`): each start
  of this process costs seconds of `import tensorflow`.

The graphs are built by coach_graph.py and run by runtimes.py, both imported only here.
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

from racer.model_io.tensorflow.coach_graph import build_graph, load_weights
from racer.model_io.tensorflow.runtimes import read_graph_def, run_litert, run_openvino, run_tensorflow

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
        "Tanh",
        "Rsqrt",
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
"""Op types of RL Coach's PPO and SAC inference paths (with your own network's tanh and inference-mode batch-norm);
any other op is a layer racer's networks do not have."""
WEIGHT_SUFFIXES = (
    "/kernel",
    "/bias",
    "_rescalers",
    "policy_log_std",
    "/gamma",
    "/beta",
    "/moving_mean",
    "/moving_variance",
)
"""Constants read back as weights whatever their size (a one-unit layer's are single numbers)."""


# --------------------------------------------------------------------------------------------------------------------
# Export (the graphs: coach_graph.py)


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
            load_weights(session, variables, arrays, default_rescaler=True)
            frozen = tf.compat.v1.graph_util.convert_variables_to_constants(
                session, graph.as_graph_def(), [spec["output_node"]]
            )
        Path(request["frozen_path"]).write_bytes(frozen.SerializeToString())
        result["frozen_nodes"] = len(frozen.node)
    if request.get("checkpoint_prefix"):
        graph, _, variables, _ = build_graph(spec, with_value=True)
        with graph.as_default(), tf.compat.v1.Session(graph=graph) as session:
            load_weights(session, variables, arrays)
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


def command_read_frozen(request: dict, arrays: dict) -> tuple[dict, dict]:
    graph_def = read_graph_def(request["frozen_path"])
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
            if name.endswith(WEIGHT_SUFFIXES) or value.size > 1:
                tensors[name] = np.ascontiguousarray(value, dtype=np.float32)
            elif value.size == 1:
                result.setdefault("scalars", {})[name] = float(value.reshape(-1)[0])
    result["output_op"] = nodes[outputs[0]].op
    return result, tensors


# --------------------------------------------------------------------------------------------------------------------
# Running: TensorFlow, OpenVINO, LiteRT (runtimes.py)


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
                    value = run_tensorflow(model["frozen_path"], feeds, model["output"])
                elif runtime in ("openvino_fp32", "openvino_fp16"):
                    value = run_openvino(
                        model["frozen_path"], feeds, model["output"], runtime.endswith("16"), Path(work), converted
                    )
                elif runtime in ("litert_fp32", "litert_fp16"):
                    value = run_litert(model["frozen_path"], feeds, model["output"], runtime.endswith("16"))
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
STEP_SEPARATOR = "#"
"""Arrays of step i travel as "<i>#<name>", both ways."""


def command_steps(request: dict, arrays: dict) -> tuple[dict, dict]:
    """request["steps"]: [{"command", ...its request}], run in order; step i sees the arrays "<i>#<name>"."""
    results, tensors = [], {}
    for index, step in enumerate(request["steps"]):
        prefix = f"{index}{STEP_SEPARATOR}"
        own = {name.removeprefix(prefix): value for name, value in arrays.items() if name.startswith(prefix)}
        result, produced = COMMANDS[step["command"]](step, own)
        results.append(result)
        tensors.update({f"{prefix}{name}": value for name, value in produced.items()})
    return {"steps": results}, tensors


def main(argv: list[str]) -> int:
    work = Path(argv[1])
    request = json.loads((work / "request.json").read_text())
    arrays_path = work / "arrays.safetensors"
    arrays = load_file(str(arrays_path)) if arrays_path.exists() else {}
    command = command_steps if request["command"] == "steps" else COMMANDS[request["command"]]
    result, tensors = command(request, arrays)
    save_file(tensors, str(work / "result.safetensors"))
    (work / "result.json").write_text(json.dumps(result))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
