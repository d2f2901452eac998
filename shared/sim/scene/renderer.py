"""Which device renders the camera: the CPU (Mesa's llvmpipe) or a GPU (NVIDIA's EGL), chosen before `mujoco` loads.

MuJoCo renders headless through EGL, and glvnd's EGL loader picks a vendor library from the JSON files in its vendor
folders (`__EGL_VENDOR_LIBRARY_FILENAMES` names them instead). `cpu` names Mesa's file, so llvmpipe draws the frames;
`gpu` names NVIDIA's, so the GPU does; `auto` leaves glvnd its own order (NVIDIA's `10_nvidia.json` before Mesa's
`50_mesa.json` where both exist), which is what racer did before the choice existed. An explicit `MUJOCO_GL` stays
the override: the choice then changes nothing and says so. Frames are the same scene drawn by another rasteriser;
the transfer benchmark is the check that a policy sees no difference.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from collections.abc import Iterable, Mapping, MutableMapping
from dataclasses import dataclass
from pathlib import Path

RENDERER_NAMES = ("auto", "cpu", "gpu")
EGL_VENDOR_VARIABLE = "__EGL_VENDOR_LIBRARY_FILENAMES"
EGL_VENDOR_DIRS: tuple[Path, ...] = (
    Path("/etc/glvnd/egl_vendor.d"),
    Path("/usr/share/glvnd/egl_vendor.d"),
    Path("/usr/local/nvidia/share/glvnd/egl_vendor.d"),  # where NVIDIA's container toolkit mounts the driver's files
)
"""glvnd's own vendor folders (its defaults), then the NVIDIA container toolkit's."""
PROBE_TIMEOUT_S = 60.0
_PROBE = (
    "import mujoco; c = mujoco.GLContext(16, 16); c.make_current()\n"
    "from OpenGL import GL; print(GL.glGetString(GL.GL_RENDERER).decode()); c.free()"
)


class RendererError(RuntimeError):
    """The renderer asked for is not on this machine."""


@dataclass(frozen=True)
class RendererChoice:
    requested: str
    """auto, cpu or gpu."""
    mujoco_gl: str
    """The MUJOCO_GL the processes render with."""
    vendor_files: tuple[str, ...]
    """The EGL vendor files named for glvnd; empty when glvnd chooses (auto) or the backend is not EGL."""
    overridden: bool
    """MUJOCO_GL was set by the user, so the choice changed nothing."""


def vendor_files(dirs: Iterable[Path] = EGL_VENDOR_DIRS) -> dict[str, list[Path]]:
    """The EGL vendor files found, as {"gpu": NVIDIA's, "cpu": Mesa's}, each in folder order."""
    found: dict[str, list[Path]] = {"gpu": [], "cpu": []}
    for folder in dirs:
        for path in sorted(folder.glob("*.json")) if folder.is_dir() else ():
            try:
                library = str(json.loads(path.read_text())["ICD"]["library_path"])
            except (OSError, ValueError, KeyError, TypeError):
                continue  # not a vendor file glvnd could load either
            if "nvidia" in library.lower():
                found["gpu"].append(path)
            elif "mesa" in library.lower():
                found["cpu"].append(path)
    return found


def choose_renderer(
    requested: str, environ: Mapping[str, str] = os.environ, dirs: Iterable[Path] = EGL_VENDOR_DIRS
) -> RendererChoice:
    """What `requested` means on this machine; a RendererError names what is missing."""
    if requested not in RENDERER_NAMES:
        raise RendererError(f"renderer {requested!r}: expected one of {', '.join(RENDERER_NAMES)}")
    explicit = environ.get("MUJOCO_GL", "").strip().lower()
    if explicit:
        return RendererChoice(requested, explicit, (), overridden=requested != "auto")
    if requested == "auto":
        return RendererChoice(requested, "", (), overridden=False)
    files = vendor_files(dirs)[requested]
    if files:
        return RendererChoice(requested, "egl", (str(files[0]),), overridden=False)
    if requested == "cpu":
        return RendererChoice(requested, "osmesa", (), overridden=False)  # Mesa without EGL: OSMesa is llvmpipe too
    folders = ", ".join(str(folder) for folder in dirs)
    raise RendererError(
        f"--renderer gpu: no NVIDIA EGL vendor file (a JSON whose library_path names libEGL_nvidia) in {folders}; "
        "install the NVIDIA driver's EGL library, or use --renderer cpu"
    )


def apply_renderer(choice: RendererChoice, environ: MutableMapping[str, str] = os.environ) -> None:
    """Set the choice in `environ` (before `mujoco` is imported); child processes inherit it."""
    if choice.overridden or not choice.mujoco_gl:
        return
    environ["MUJOCO_GL"] = choice.mujoco_gl
    if choice.vendor_files:
        environ[EGL_VENDOR_VARIABLE] = ":".join(choice.vendor_files)


def gl_renderer_name(environ: Mapping[str, str] = os.environ) -> str:
    """The GL_RENDERER string a child process with `environ` renders with (e.g. "llvmpipe (LLVM 15.0.6, 256 bits)"
    or "NVIDIA H200/PCIe/SSE2"); a RendererError carries the child's error."""
    env = dict(environ)
    env.setdefault("MUJOCO_GL", "egl")
    env.pop("PYOPENGL_PLATFORM", None)
    try:
        result = subprocess.run(
            [sys.executable, "-c", _PROBE], env=env, capture_output=True, text=True, timeout=PROBE_TIMEOUT_S
        )
    except subprocess.TimeoutExpired as error:
        raise RendererError(f"the renderer probe timed out after {PROBE_TIMEOUT_S:g} s") from error
    if result.returncode != 0:
        lines = result.stderr.strip().splitlines() or [f"exit code {result.returncode}"]
        raise RendererError(f"MUJOCO_GL={env['MUJOCO_GL']}: {lines[-1]}")
    return result.stdout.strip().splitlines()[-1]


def is_software_renderer(gl_renderer: str) -> bool:
    """Mesa's CPU rasterisers name themselves llvmpipe or softpipe."""
    return any(name in gl_renderer.lower() for name in ("llvmpipe", "softpipe"))
