"""`--renderer auto|cpu|gpu`: which EGL vendor draws the camera, read from glvnd's vendor files; MUJOCO_GL overrides."""

from __future__ import annotations

import json
import os

import pytest

from racer.shared.sim.scene.renderer import (
    EGL_VENDOR_DIRS,
    EGL_VENDOR_VARIABLE,
    RendererError,
    apply_renderer,
    choose_renderer,
    gl_renderer_name,
    is_software_renderer,
    vendor_files,
)


def _vendor(folder, name, library):
    folder.mkdir(exist_ok=True)
    (folder / name).write_text(json.dumps({"file_format_version": "1.0.0", "ICD": {"library_path": library}}))


def test_vendor_files_are_told_apart_by_their_library(tmp_path):
    _vendor(tmp_path / "a", "10_nvidia.json", "libEGL_nvidia.so.0")
    _vendor(tmp_path / "b", "50_mesa.json", "libEGL_mesa.so.0")
    (tmp_path / "b" / "broken.json").write_text("{not json")
    found = vendor_files([tmp_path / "a", tmp_path / "b", tmp_path / "missing"])
    assert found == {"gpu": [tmp_path / "a" / "10_nvidia.json"], "cpu": [tmp_path / "b" / "50_mesa.json"]}


def test_each_choice_names_its_vendor_and_gpu_without_nvidia_is_refused(tmp_path):
    _vendor(tmp_path, "50_mesa.json", "libEGL_mesa.so.0")
    cpu = choose_renderer("cpu", environ={}, dirs=[tmp_path])
    assert (cpu.mujoco_gl, cpu.vendor_files, cpu.overridden) == ("egl", (str(tmp_path / "50_mesa.json"),), False)
    with pytest.raises(RendererError, match="no NVIDIA EGL vendor file"):
        choose_renderer("gpu", environ={}, dirs=[tmp_path])
    _vendor(tmp_path, "10_nvidia.json", "libEGL_nvidia.so.0")
    assert choose_renderer("gpu", environ={}, dirs=[tmp_path]).vendor_files == (str(tmp_path / "10_nvidia.json"),)
    assert choose_renderer("cpu", environ={}, dirs=[tmp_path / "none"]).mujoco_gl == "osmesa"
    auto = choose_renderer("auto", environ={}, dirs=[tmp_path])
    environ: dict[str, str] = {}
    apply_renderer(auto, environ)
    assert environ == {}  # auto leaves glvnd its own order, as racer did before the choice


def test_mujoco_gl_overrides_the_choice():
    choice = choose_renderer("gpu", environ={"MUJOCO_GL": "osmesa"}, dirs=[])
    assert (choice.mujoco_gl, choice.overridden) == ("osmesa", True)
    environ = {"MUJOCO_GL": "osmesa"}
    apply_renderer(choice, environ)
    assert environ == {"MUJOCO_GL": "osmesa"}
    with pytest.raises(RendererError, match="expected one of auto, cpu, gpu"):
        choose_renderer("vulkan", environ={})


def test_the_cpu_renderer_draws_with_llvmpipe_here():
    """The real probe: `cpu` on this machine's Mesa renders with a software rasteriser."""
    choice = choose_renderer("cpu", environ={}, dirs=EGL_VENDOR_DIRS)
    environ = {key: value for key, value in os.environ.items() if key not in ("MUJOCO_GL", EGL_VENDOR_VARIABLE)}
    apply_renderer(choice, environ)
    name = gl_renderer_name(environ)
    assert is_software_renderer(name), name
    assert not is_software_renderer("NVIDIA H200/PCIe/SSE2")
