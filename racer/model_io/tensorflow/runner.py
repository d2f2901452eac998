"""Runs one TensorFlow step (tool.py) in a fresh Python process and brings its result back.

Why a process per step: `import tensorflow` in a process that has rendered with Mesa (EGL or OSMesa) segfaults, and
racer's evaluation, tests and CLI render. The request travels as `request.json` + `arrays.safetensors` in a private
temporary folder (no pickle); the answer as `result.json` + `result.safetensors`.
"""

from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
import tempfile
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
from safetensors.numpy import load_file, save_file

__all__ = [
    "INSTALL_HINT",
    "TensorFlowMissingError",
    "TensorFlowToolError",
    "require_tensorflow",
    "run_tool",
    "run_tools",
    "tensorflow_available",
]

TOOL_MODULE = "racer.model_io.tensorflow.tool"
INSTALL_HINT = (
    "install racer's optional TensorFlow extra (tensorflow-cpu, openvino, ai-edge-litert, ~1 GB): "
    "`.venv/bin/python -m pip install -e '.[tensorflow]'` in the racer checkout "
    "(scripts/setup.sh installs it too)"
)


class TensorFlowMissingError(RuntimeError):
    """The optional extra is not installed; the message says how to install it."""


class TensorFlowToolError(RuntimeError):
    """The TensorFlow process failed; the message holds the end of its error output."""


def tensorflow_available() -> bool:
    return importlib.util.find_spec("tensorflow") is not None


def require_tensorflow(what: str) -> None:
    if not tensorflow_available():
        raise TensorFlowMissingError(f"{what} needs TensorFlow, which is not installed: {INSTALL_HINT}")


def run_tool(
    command: str, request: Mapping, arrays: Mapping[str, np.ndarray] | None = None, timeout_s: float = 1800.0
) -> tuple[dict, dict[str, np.ndarray]]:
    """Run `command` of tool.py in its own interpreter. Returns (result JSON, result arrays)."""
    require_tensorflow(f"`{command}`")
    with tempfile.TemporaryDirectory(prefix="racer-tf-") as folder:
        work = Path(folder)
        (work / "request.json").write_text(json.dumps({**request, "command": command}))
        if arrays:
            save_file(
                {name: np.ascontiguousarray(value) for name, value in arrays.items()}, str(work / "arrays.safetensors")
            )
        environment = {
            **os.environ,
            "TF_CPP_MIN_LOG_LEVEL": "2",
            "CUDA_VISIBLE_DEVICES": "",
            "PYTHONWARNINGS": "ignore",
            # `import tensorflow` imports Keras eagerly unless told the legacy tf_keras package is wanted; racer's
            # extra does not install that, so the eager import is skipped: about a third of the step's start-up
            # (1.4 s of 4.6 s on 2 shared cores). The tool's graphs are plain TensorFlow ops, its converters read
            # frozen graphs: nothing in this process uses Keras.
            "TF_USE_LEGACY_KERAS": "1",
        }
        completed = subprocess.run(
            [sys.executable, "-m", TOOL_MODULE, str(work)],
            capture_output=True,
            text=True,
            env=environment,
            timeout=timeout_s,
            check=False,
        )
        if completed.returncode != 0:
            tail = "\n".join(completed.stderr.strip().splitlines()[-15:])
            raise TensorFlowToolError(f"TensorFlow step {command!r} failed (exit {completed.returncode}):\n{tail}")
        result = json.loads((work / "result.json").read_text())
        tensors = load_file(str(work / "result.safetensors"))
    return result, tensors


def run_tools(
    steps: Sequence[tuple[str, Mapping, Mapping[str, np.ndarray] | None]], timeout_s: float = 1800.0
) -> list[tuple[dict, dict[str, np.ndarray]]]:
    """Several (command, request, arrays) steps in order in one TensorFlow process, which starts once: `run_tool`'s
    answer for each step."""
    separator = "#"  # tool.STEP_SEPARATOR (tool.py imports TensorFlow: never imported here)
    arrays = {
        f"{index}{separator}{name}": value
        for index, (_, _, given) in enumerate(steps)
        for name, value in (given or {}).items()
    }
    requests = [{**request, "command": command} for command, request, _ in steps]
    result, tensors = run_tool("steps", {"steps": requests}, arrays, timeout_s)
    answers = []
    for index, step_result in enumerate(result["steps"]):
        prefix = f"{index}{separator}"
        answers.append(
            (
                step_result,
                {name.removeprefix(prefix): value for name, value in tensors.items() if name.startswith(prefix)},
            )
        )
    return answers
