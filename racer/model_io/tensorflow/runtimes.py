"""Run a frozen inference graph (`.pb`) with TensorFlow, or with the OpenVINO IR and LiteRT models converted from it
(fp32 or fp16), one row at a time as the car does.

Runs only inside the TensorFlow process (`python -m racer.model_io.tensorflow.tool`, started by runner.py), which
switches TensorFlow to graph mode first; never import it in a racer process (see tool.py).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import tensorflow as tf


def read_graph_def(path: str):
    """The GraphDef of a frozen graph file (`.pb`)."""
    graph_def = tf.compat.v1.GraphDef()
    graph_def.ParseFromString(Path(path).read_bytes())
    return graph_def


def run_tensorflow(path: str, feeds: dict, output: str) -> np.ndarray:
    graph = tf.Graph()
    with graph.as_default():
        tf.compat.v1.import_graph_def(read_graph_def(path), name="")
    with tf.compat.v1.Session(graph=graph) as session:
        return session.run(f"{output}:0", {f"{name}:0": value for name, value in feeds.items()})


def run_openvino(path: str, feeds: dict, output: str, fp16: bool, work: Path, converted: dict) -> np.ndarray:
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


def run_litert(path: str, feeds: dict, output: str, fp16: bool) -> np.ndarray:
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
