"""Product code imports nothing from the repository's `benchmarks/` (what measures racer), `research/` (one-off
studies) or `tools/` (generators run against a SimApp checkout): the wheel installs none of them, so such an import
would work in a checkout and fail for a user. `research/` may import `benchmarks/`; `benchmarks/` never imports
`research/`.

Read from the source: every import statement under the folders setup.py maps to `racer`, at module level or inside
a function, and every string that names a module the way a lazy command does (`research.x:command`). Then, in a
fresh interpreter that refuses to import `research` and `tools`, every product module is imported.
"""

from __future__ import annotations

import ast
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from tests.foundation.test_imports import MODULES, ROOT

FORBIDDEN = ("benchmarks", "research", "tools")
NOT_IMPORTABLE_HERE = {
    "racer.model_io.tensorflow.tool": "runs in its own TensorFlow interpreter (runner.py), never imported by racer",
}
"""Product modules the import check leaves out, each with the reason."""


def _forbidden(name: str) -> bool:
    return name.split(".", 1)[0] in FORBIDDEN


def forbidden_references(source: str, filename: str = "<source>") -> list[str]:
    """`line: name` for each import of `research` or `tools` (absolute, anywhere in the file) and each string
    constant that names one of their modules as a lazy command does (`research.x` or `research.x:attr`)."""
    found = []
    for node in ast.walk(ast.parse(source, filename=filename)):
        names: list[str] = []
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names = [node.module]
        elif isinstance(node, ast.Constant) and isinstance(node.value, str):
            target = node.value.split(":", 1)[0]
            if target.replace(".", "").replace("_", "").isalnum() and "." in target:
                names = [target]
        found += [f"{node.lineno}: {name}" for name in names if _forbidden(name)]
    return found


def test_the_check_sees_every_kind_of_reference():
    source = """
import research.tyre_fit
from tools import track_looks_from_simapp
def later():
    from research.frame_pairs.fit import fit_pose
COMMANDS = {"x": ("research.camera_proxies.camera:camera_command", "help")}
"""
    assert forbidden_references(source) == [
        "2: research.tyre_fit",
        "3: tools",
        "5: research.frame_pairs.fit",
        "6: research.camera_proxies.camera",
    ]
    assert forbidden_references("from benchmarks.sim import sim_bench_command") == ["1: benchmarks.sim"]
    assert forbidden_references("import researcher\nfrom racer.tools import x\nTEXT = 'see research.'\n") == []


@pytest.mark.parametrize("module", sorted(MODULES))
def test_product_modules_do_not_import_benchmarks_research_or_tools(module):
    path = MODULES[module]
    found = forbidden_references(path.read_text(encoding="utf-8"), str(path))
    assert not found, f"{path.relative_to(ROOT)} refers to {found}: benchmarks/, research/ and tools/ are not installed"


@pytest.mark.parametrize("path", sorted((ROOT / "benchmarks").rglob("*.py")), ids=lambda path: path.stem)
def test_benchmarks_never_import_research(path):
    found = [ref for ref in forbidden_references(path.read_text(encoding="utf-8"), str(path)) if "research" in ref]
    assert not found, f"{path.relative_to(ROOT)} refers to {found}: research may import benchmarks, not the reverse"


_PROBE = """
import importlib, importlib.abc, json, sys

class Refuse(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path=None, target=None):
        if name.split(".", 1)[0] in {forbidden!r}:
            raise ModuleNotFoundError(f"{{name}} is not installed with racer", name=name)
        return None

sys.meta_path.insert(0, Refuse())
failed = {{}}
for name in sys.argv[1:]:
    try:
        importlib.import_module(name)
    except ImportError as error:
        failed[name] = repr(error)
print(json.dumps(failed))
"""


@pytest.mark.slow
def test_every_product_module_imports_without_benchmarks_research_or_tools(tmp_path):
    """A fresh interpreter outside the checkout (so the repository root is not on sys.path through the working
    folder), with `benchmarks`, `research` and `tools` refused outright, imports every product module."""
    modules = sorted(set(MODULES) - set(NOT_IMPORTABLE_HERE))
    result = subprocess.run(
        [sys.executable, "-c", _PROBE.format(forbidden=set(FORBIDDEN)), *modules],
        capture_output=True,
        text=True,
        timeout=600,
        cwd=tmp_path,
        env={**{k: v for k, v in os.environ.items() if k != "PYTHONPATH"}, "MUJOCO_GL": "egl"},
    )
    assert result.returncode == 0, result.stderr[-3000:]
    assert json.loads(result.stdout.strip().splitlines()[-1]) == {}


def test_the_probe_refuses_research(tmp_path):
    result = subprocess.run(
        [sys.executable, "-c", _PROBE.format(forbidden=set(FORBIDDEN)), "research", "json"],
        capture_output=True,
        text=True,
        timeout=60,
        cwd=Path(__file__).resolve().parents[2],
    )
    assert result.returncode == 0, result.stderr
    failed = json.loads(result.stdout.strip().splitlines()[-1])
    assert list(failed) == ["research"] and "not installed with racer" in failed["research"]
