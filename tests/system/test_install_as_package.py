"""racer installs as a package: its wheel, installed (not editable) into a fresh virtual environment, trains one
iteration in an empty folder, finding redis.conf and the example custom files in the installed package (racer/defaults), not in a
source tree.

How the fresh environment gets racer's dependencies without a download: `python -m venv` makes it, and one .pth
file in its site-packages names the project .venv's site-packages folder. A folder named in a .pth file is added to
sys.path after the environment's own site-packages, and the .pth files inside it are not run, so the editable
install's finder (`__editable__.racer_deepracer-*.pth` there) never loads: `racer` can only come from the fresh
environment, where pip installs it from the wheel alone (`--no-deps --no-index`). The test checks that
`racer.__file__` lies in the fresh environment.

The wheel is built from a copy of what the Dockerfile copies (pyproject.toml, setup.py, README.md, redis.conf and
setup.py's PACKAGE_DIRS folders), so no build/ folder left in the checkout by an earlier build can add a file to it.
The wheel holds no benchmark (`benchmarks/` stays in the repository) and carries the top-level redis.conf's text;
the installed `racer bench` says where the benchmarks went.
"""

from __future__ import annotations

import ast
import json
import os
import shutil
import subprocess
import sys
import sysconfig
import zipfile
from pathlib import Path

import pytest

pytestmark = [pytest.mark.slow, pytest.mark.heavy]  # a pip build and a training run

ROOT = Path(__file__).resolve().parents[2]


def package_folders() -> list[str]:
    """The folders setup.py maps onto the racer package (its PACKAGE_DIRS), read without running setup()."""
    tree = ast.parse((ROOT / "setup.py").read_text())
    for node in tree.body:
        if isinstance(node, ast.Assign) and any(getattr(t, "id", None) == "PACKAGE_DIRS" for t in node.targets):
            return sorted(set(ast.literal_eval(node.value).values()))
    raise AssertionError("setup.py: no PACKAGE_DIRS assignment")


def run(command: list[str], **kwargs) -> subprocess.CompletedProcess:
    result = subprocess.run(command, capture_output=True, text=True, **kwargs)
    assert result.returncode == 0, (
        f"{command} exited {result.returncode}:\n{result.stdout[-3000:]}{result.stderr[-3000:]}"
    )
    return result


def test_the_wheel_installs_in_a_fresh_environment_and_trains_in_an_empty_folder(tmp_path):
    source = tmp_path / "source"
    source.mkdir()
    for name in ("pyproject.toml", "setup.py", "README.md", "redis.conf"):
        shutil.copy2(ROOT / name, source / name)
    ignored = shutil.ignore_patterns("__pycache__", "*.pyc", "*.egg-info")
    for folder in package_folders():
        shutil.copytree(ROOT / folder, source / folder, ignore=ignored)
    wheels = tmp_path / "wheels"
    run(
        [
            sys.executable,
            "-m",
            "pip",
            "wheel",
            "-q",
            "--no-deps",
            "--no-build-isolation",
            "-w",
            str(wheels),
            str(source),
        ]
    )
    (wheel,) = wheels.glob("racer_deepracer-*.whl")
    with zipfile.ZipFile(wheel) as archive:
        names = archive.namelist()
        assert archive.read("racer/defaults/redis.conf") == (ROOT / "redis.conf").read_bytes()
    benchmark_files = [name for name in names if name.startswith(("benchmarks/", "racer/benches/", "research/"))]
    assert not benchmark_files, f"the wheel carries what measures racer: {benchmark_files[:5]}"
    assert "racer/shared/sim/env.py" in names and "racer/racing_line/__init__.py" in names

    venv = tmp_path / "venv"
    run([sys.executable, "-m", "venv", "--without-pip", str(venv)])
    python = venv / "bin" / "python"
    site_packages = Path(
        run([str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"]).stdout.strip()
    )
    (site_packages / "project-dependencies.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    run([sys.executable, "-m", "pip", "--python", str(python), "install", "-q", "--no-deps", "--no-index", str(wheel)])

    empty = tmp_path / "empty"
    empty.mkdir()
    env = {key: value for key, value in os.environ.items() if not key.startswith("RACER_") and key != "PYTHONPATH"}
    env["MUJOCO_GL"] = os.environ.get("MUJOCO_GL", "egl")
    where = run(
        [
            str(python),
            "-c",
            "import racer, racer.defaults as d; print(racer.__file__, d.REDIS_CONF, d.DEFAULT_CUSTOM_FILES)",
        ],
        cwd=empty,
        env=env,
    ).stdout.split()
    for path in where:
        assert Path(path).is_relative_to(venv), f"{path} is not in the fresh environment {venv}"
    hyperparameters = json.loads((Path(where[2]) / "hyperparameters.json").read_text())
    bench = subprocess.run(
        [str(venv / "bin" / "racer"), "bench", "sim"], cwd=empty, env=env, capture_output=True, text=True, timeout=120
    )
    assert bench.returncode == 1 and "python -m benchmarks" in bench.stderr, bench.stdout + bench.stderr

    # `racer train` with the installed example files, stopped after one iteration's episodes.
    one_iteration = str(hyperparameters["num_episodes_between_training"])
    training = subprocess.run(
        [str(venv / "bin" / "racer"), "train", "--max-episodes", one_iteration, "--workers", "2", "--viewer-port", "0"]
        + ["--model-prefix", "from-the-wheel"],
        cwd=empty,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    output = training.stdout + training.stderr
    assert training.returncode == 0, output[-4000:]
    model = empty / "racer-data" / "from-the-wheel" / "model"
    assert (model / ".coach_checkpoint").read_text().startswith("1_Step-"), output[-3000:]
    assert (model / ".finished").is_file(), output[-3000:]
