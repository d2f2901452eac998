"""Environment variables are read in one module (racer.shared.config), so every other module gets its settings as
values and a test or a child process can set them explicitly. Parsed with `ast`: no module is imported."""

from __future__ import annotations

import ast
from pathlib import Path

from tests.shared_data import REPO_ROOT

PRODUCT_FOLDERS = ("racer", "shared", "trainer", "rollout_worker", "evaluation_worker", "tracks")
"""The folders setup.py installs as the `racer` package."""

READERS: dict[str, str] = {
    "shared/config.py": "the one module that reads the environment",
    "shared/sim/scene/gl.py": "chooses MUJOCO_GL and sets it before mujoco is imported (MuJoCo reads it once, at import)",
    "shared/sim/scene/renderer.py": "sets MUJOCO_GL and glvnd's EGL vendor file before mujoco is imported, MUJOCO_GL the override",
}
"""Files that may read the environment in any way, and why."""

LAUNCHERS: dict[str, str] = {
    "racer/local/run.py": "`racer train` gives its trainer and rollout workers the service settings on top of its own",
    "racer/local/services.py": "redis-server and MinIO start with the launcher's environment",
    "racer/race/runner.py": "race worker processes inherit the environment with their thread counts pinned",
    "racer/model_io/tensorflow/runner.py": "the TensorFlow interpreter runs with the caller's environment",
    "benchmarks/race.py": "the race bench runs `racer race` and `racer evaluate` as the user would",
}
"""Files that may copy the whole environment into a child process's (`dict(os.environ)`, `{**os.environ, ...}`), and
why; any other read there (`os.environ[...]`, `.get`, `os.getenv`) still fails."""

ENVIRONMENT_NAMES = frozenset({"environ", "environb", "getenv", "getenvb", "putenv", "unsetenv"})


def _is_whole_copy(node: ast.AST, parents: dict[ast.AST, ast.AST]) -> bool:
    """`dict(os.environ, ...)` or `{**os.environ, ...}`: the environment handed on unread."""
    parent = parents.get(node)
    if isinstance(parent, ast.Call) and parent.args and parent.args[0] is node:
        return isinstance(parent.func, ast.Name) and parent.func.id == "dict"
    if isinstance(parent, ast.Dict):
        return any(key is None and value is node for key, value in zip(parent.keys, parent.values, strict=True))
    return False


def environment_reads(source: str) -> list[tuple[int, str, bool]]:
    """(line, what, whole copy) for every use of the process environment through the `os` module."""
    tree = ast.parse(source)
    parents = {child: node for node in ast.walk(tree) for child in ast.iter_child_nodes(node)}
    os_names = {"os"}
    found: list[tuple[int, str, bool]] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            os_names |= {alias.asname or alias.name for alias in node.names if alias.name == "os"}
        elif isinstance(node, ast.ImportFrom) and node.module == "os":
            for alias in node.names:
                if alias.name in ENVIRONMENT_NAMES:
                    found.append((node.lineno, f"from os import {alias.name}", False))
    for node in ast.walk(tree):
        if (
            isinstance(node, ast.Attribute)
            and node.attr in ENVIRONMENT_NAMES
            and isinstance(node.value, ast.Name)
            and node.value.id in os_names
        ):
            found.append((node.lineno, f"{node.value.id}.{node.attr}", _is_whole_copy(node, parents)))
    return sorted(found)


def product_files() -> list[Path]:
    return sorted(
        path
        for folder in PRODUCT_FOLDERS
        for path in (REPO_ROOT / folder).rglob("*.py")
        if "__pycache__" not in path.parts
    )


def test_only_the_settings_module_reads_the_environment():
    offending = []
    for path in product_files():
        relative = path.relative_to(REPO_ROOT).as_posix()
        if relative in READERS:
            continue
        for line, what, whole_copy in environment_reads(path.read_text(encoding="utf-8")):
            if not (whole_copy and relative in LAUNCHERS):
                offending.append(f"{relative}:{line}: {what}")
    assert offending == [], "read the setting in racer.shared.config and pass the value:\n" + "\n".join(offending)


def test_the_allowed_files_exist_and_use_the_environment():
    """A renamed or cleaned-up file must leave the lists, so they never allow more than they name."""
    for relative in (*READERS, *LAUNCHERS):
        path = REPO_ROOT / relative
        assert path.is_file(), relative
        assert environment_reads(path.read_text(encoding="utf-8")), f"{relative} no longer uses the environment"


def test_every_form_of_read_is_found_and_only_a_whole_copy_counts_as_one():
    source = """
import os
import os as system
from os import environ, getenv

a = os.environ.get("A")
b = os.environ["B"]
c = system.getenv("C")
d = dict(os.environ)
e = {**os.environ, "F": "1"}
f = dict(os.environ, G="1")
g = dict(os.environ.items())
os.path.join("a", "b")
"""
    assert environment_reads(source) == [
        (4, "from os import environ", False),
        (4, "from os import getenv", False),
        (6, "os.environ", False),
        (7, "os.environ", False),
        (8, "system.getenv", False),
        (9, "os.environ", True),
        (10, "os.environ", True),
        (11, "os.environ", True),
        (12, "os.environ", False),
    ]
