"""Choosing MuJoCo's headless OpenGL backend before `mujoco` is imported.

MuJoCo reads `MUJOCO_GL` once, when `mujoco` is first imported. An explicit `MUJOCO_GL` is always honoured.
When it is unset, EGL is tried first and OSMesa second, each in a short-lived child process (a failed EGL
initialisation cannot be undone inside this process); the working one is written to `MUJOCO_GL` so child
processes inherit the choice without probing again.
"""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Callable, Collection, Mapping, MutableMapping

HEADLESS_BACKENDS = ("egl", "osmesa")
PROBE_TIMEOUT_S = 60.0
_PROBE = "import mujoco; c = mujoco.GLContext(16, 16); c.make_current(); c.free()"


class GLBackendError(RuntimeError):
    """No usable OpenGL backend for offscreen rendering."""


def keep_triton_out(imported_modules: MutableMapping[str, object] = sys.modules) -> None:
    """Stop torch from loading its optional GPU compiler, triton, into a process that renders with Mesa.

    triton carries its own LLVM; loaded next to Mesa's llvmpipe (also LLVM) it crashes the process with a
    segmentation fault. torch imports it lazily, e.g. the first time an optimiser is created after rendering.
    We run torch on the CPU and never compile for a GPU, so a missing triton costs nothing.
    """
    if "triton" not in imported_modules:
        imported_modules["triton"] = None  # `import triton` now raises ImportError; torch treats it as absent


def probe_backend(backend: str) -> str | None:
    """None when `backend` can create a GL context, else the child's error output."""
    env = dict(os.environ, MUJOCO_GL=backend)
    env.pop("PYOPENGL_PLATFORM", None)
    try:
        result = subprocess.run(
            [sys.executable, "-c", _PROBE],
            env=env,
            capture_output=True,
            text=True,
            timeout=PROBE_TIMEOUT_S,
            check=False,
        )
    except subprocess.TimeoutExpired:
        return f"timed out after {PROBE_TIMEOUT_S:g} s"
    if result.returncode == 0:
        return None
    return (result.stderr.strip().splitlines() or [f"exit code {result.returncode}"])[-1]


def chosen_backend(environ: Mapping[str, str] = os.environ) -> str:
    """The MUJOCO_GL this process renders with ('' when none was chosen), for error messages."""
    return environ.get("MUJOCO_GL", "")


def ensure_gl_backend(
    environ: MutableMapping[str, str] = os.environ,
    imported_modules: Collection[str] = sys.modules,
    probe: Callable[[str], str | None] = probe_backend,
) -> str:
    """The backend MuJoCo will use; picks egl, else osmesa, when MUJOCO_GL is unset (call before importing mujoco)."""
    keep_triton_out()
    requested = environ.get("MUJOCO_GL", "").strip().lower()
    if requested:
        return requested
    if "mujoco" in imported_modules:
        raise GLBackendError(
            "mujoco was imported before MUJOCO_GL was set, so it cannot render headless; "
            "set MUJOCO_GL=egl (or osmesa) in the environment"
        )
    failures = []
    for backend in HEADLESS_BACKENDS:
        problem = probe(backend)
        if problem is None:
            environ["MUJOCO_GL"] = backend
            return backend
        failures.append(f"MUJOCO_GL={backend}: {problem}")
    raise GLBackendError(
        "no headless OpenGL backend works (" + "; ".join(failures) + "). Install EGL (libegl1 + a Mesa or GPU driver) "
        "or OSMesa (libosmesa6), or set MUJOCO_GL explicitly"
    )
