"""The import contracts of the house, read from the source (no module is imported):

- `shared/` (`racer.shared`) is what the roles share: it never imports a role (`racer.trainer`,
  `racer.rollout_worker`, `racer.evaluation_worker`) nor racer's own command-line packages (any `racer.*` but
  `racer.shared` and `racer.tracks`), at module level or inside a function.
- No import loops among racer's modules: the graph of module-level imports (every `import` statement not inside a
  function; `if TYPE_CHECKING:` blocks excluded, they never run) has no cycle; and with the imports inside functions
  added as edges (a deferred import hides a loop rather than removing it) there is no cycle either
  (`KNOWN_DEFERRED_LOOPS` would list one allowed; it is empty); a new one fails.

Every non-test Python file under the folders setup.py maps to `racer` is checked (tests/ and shared/deepracer-data
are not racer modules).
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PACKAGE_DIRS = {
    "racer": "racer",
    "racer.shared": "shared",
    "racer.trainer": "trainer",
    "racer.rollout_worker": "rollout_worker",
    "racer.evaluation_worker": "evaluation_worker",
    "racer.tracks": "tracks",
}
ROLES = ("racer.trainer", "racer.rollout_worker", "racer.evaluation_worker")
SHARED_MAY_IMPORT = ("racer.shared", "racer.tracks")


def _modules() -> dict[str, Path]:
    modules = {}
    for package, folder in PACKAGE_DIRS.items():
        for path in sorted((ROOT / folder).rglob("*.py")):
            parts = path.relative_to(ROOT / folder).with_suffix("").parts
            if parts[-1] == "__init__":
                parts = parts[:-1]
            modules[".".join((package, *parts))] = path
    return modules


MODULES = _modules()


def _is_type_checking(node: ast.If) -> bool:
    test = node.test
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def _imported(module: str, node: ast.Import | ast.ImportFrom) -> list[str]:
    """Racer modules an import statement names (`from a import b` names a.b when b is a module, else a)."""
    if isinstance(node, ast.Import):
        return [alias.name for alias in node.names if alias.name.startswith("racer")]
    base = node.module or ""
    if node.level:  # relative: resolve against the importing package
        package = module if MODULES[module].name == "__init__.py" else module.rsplit(".", 1)[0]
        for _ in range(node.level - 1):
            package = package.rsplit(".", 1)[0]
        base = f"{package}.{base}" if base else package
    if not base.startswith("racer"):
        return []
    return [f"{base}.{alias.name}" if f"{base}.{alias.name}" in MODULES else base for alias in node.names]


def _imports(module: str) -> tuple[set[str], set[str]]:
    """(module-level imports, imports anywhere) of one module, as racer module names."""
    tree = ast.parse(MODULES[module].read_text(encoding="utf-8"), filename=str(MODULES[module]))
    top: set[str] = set()
    anywhere: set[str] = set()

    def visit(node: ast.AST, in_function: bool) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.If) and _is_type_checking(child):
                for item in child.orelse:
                    visit(item, in_function)
                continue
            if isinstance(child, ast.Import | ast.ImportFrom):
                names = _imported(module, child)
                anywhere.update(names)
                if not in_function:
                    top.update(names)
            visit(child, in_function or isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef | ast.Lambda))

    visit(tree, False)
    return top, anywhere


IMPORTS = {module: _imports(module) for module in MODULES}


def _within(name: str, packages: tuple[str, ...]) -> bool:
    return any(name == package or name.startswith(package + ".") for package in packages)


def test_the_walk_finds_the_house():
    assert "racer.shared.config" in MODULES and "racer.trainer.training_loop" in MODULES
    assert "racer.trainer.ppo" in IMPORTS["racer.trainer.algorithms"][0]  # module level
    user_errors_top, user_errors_anywhere = IMPORTS["racer.shared.user_errors"]
    assert "racer.shared.sim.scene.gl" in user_errors_anywhere - user_errors_top  # inside a function


@pytest.mark.parametrize("module", sorted(m for m in MODULES if _within(m, ("racer.shared",))))
def test_shared_never_imports_a_role_or_the_cli(module):
    upward = sorted(name for name in IMPORTS[module][1] if not _within(name, SHARED_MAY_IMPORT))
    assert not upward, f"{module} imports {upward}: shared/ holds what the roles share and imports none of them"


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def connect(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for target in graph.get(node, ()):
            if target not in index:
                connect(target)
                low[node] = min(low[node], low[target])
            elif target in on_stack:
                low[node] = min(low[node], index[target])
        if low[node] == index[node]:
            component = []
            while True:
                item = stack.pop()
                on_stack.discard(item)
                component.append(item)
                if item == node:
                    break
            if len(component) > 1 or node in graph.get(node, ()):
                found.append(sorted(component))

    for node in sorted(graph):
        if node not in index:
            connect(node)
    return found


def _module_graph() -> dict[str, set[str]]:
    """Module-level imports between racer modules. Importing `a.b.c` runs the packages `a` and `a.b` too, but a
    package's own `__init__` importing its children is not a loop, so only the named module is an edge."""
    graph = {}
    for module, (top, _) in IMPORTS.items():
        graph[module] = {name for name in top if name in MODULES and name != module}
    return graph


def test_the_loop_check_finds_a_loop():
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


def test_no_import_loops_among_racer_modules():
    assert _cycles(_module_graph()) == []


KNOWN_DEFERRED_LOOPS: list[list[str]] = []
"""Loops closed only by an import inside a function (none left)."""


def test_no_import_loops_even_through_imports_inside_functions():
    graph = {
        module: {name for name in anywhere if name in MODULES and name != module}
        for module, (_, anywhere) in IMPORTS.items()
    }
    assert [cycle for cycle in _cycles(graph) if cycle not in KNOWN_DEFERRED_LOOPS] == []
