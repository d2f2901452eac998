"""The README's two commands on a machine with no Go and no MinIO: `scripts/setup.sh` checks without them and
`scripts/train.sh` trains (the embedded run keeps its store in a local folder; only the tests and S3 runs need MinIO,
which `scripts/setup.sh --with-minio` builds).

Both run the scripts themselves with a PATH that holds no `go` and no `minio`, and a HOME of their own, so no
`~/go/bin` is found either. The set-up is already done (scripts/test.sh runs it first), so setup.sh only checks.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
from pathlib import Path

import pytest

from tests.conftest import write_custom_files

ROOT = Path(__file__).resolve().parents[2]


def path_without_go_or_minio() -> str:
    """This PATH less every folder that holds a `go` or a `minio` (the project's .venv/bin links minio)."""
    kept = [
        folder
        for folder in os.environ["PATH"].split(os.pathsep)
        if folder and not any(os.path.lexists(os.path.join(folder, name)) for name in ("go", "minio"))
    ]
    path = os.pathsep.join(kept)
    assert shutil.which("go", path=path) is None and shutil.which("minio", path=path) is None
    assert shutil.which("redis-server", path=path), f"redis-server is not on PATH ({path})"
    return path


def fresh_machine_environment(tmp_path: Path) -> dict[str, str]:
    """The environment of a machine without Go or MinIO, set up by scripts/setup.sh (stamps current)."""
    wanted = hashlib.sha256((ROOT / "pyproject.toml").read_bytes() + (ROOT / "setup.py").read_bytes()).hexdigest()
    stamp = ROOT / ".venv" / ".racer-installed"
    if not stamp.is_file() or stamp.read_text().strip() != wanted:
        pytest.fail(f"{stamp} does not match pyproject.toml and setup.py: run ./scripts/setup.sh first")
    home = tmp_path / "home"
    home.mkdir()
    env = {key: value for key, value in os.environ.items() if not key.startswith("RACER_")}
    env.update(PATH=path_without_go_or_minio(), HOME=str(home), MUJOCO_GL=os.environ.get("MUJOCO_GL", "egl"))
    tensorflow_stamp = ROOT / ".venv" / ".racer-tensorflow-installed"
    if not tensorflow_stamp.is_file() or tensorflow_stamp.read_text().strip() != wanted:
        env["RACER_TENSORFLOW"] = "0"  # set up without the TensorFlow extra: the check must not add it
    return env


def test_the_setup_check_needs_no_go_no_minio_and_installs_nothing(tmp_path):
    result = subprocess.run(
        [str(ROOT / "scripts" / "setup.sh")],
        env=fresh_machine_environment(tmp_path),
        capture_output=True,
        text=True,
        timeout=120,
    )
    output = result.stdout + result.stderr
    assert result.returncode == 0, output
    assert "installing" not in output and "building" not in output, output
    assert "[setup] ready:" in output and "no MinIO asked for" in output, output


@pytest.mark.slow
@pytest.mark.heavy  # a training run of its own
def test_train_sh_trains_with_no_go_and_no_minio(tmp_path):
    custom_files = write_custom_files(tmp_path / "custom_files")
    env = fresh_machine_environment(tmp_path)
    env["RACER_STORE"] = str(tmp_path / "store")
    result = subprocess.run(
        [
            str(ROOT / "scripts" / "train.sh"),
            "--custom-files",
            str(custom_files),
            "--workers",
            "1",
            "--max-episodes",
            "2",
            "--viewer-port",
            "0",
            "--model-prefix",
            "fresh-machine",
        ],
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    output = result.stdout + result.stderr
    assert result.returncode == 0, output[-4000:]
    assert "[setup] ready:" in output and "installing" not in output, output[-4000:]
    model = tmp_path / "store" / "fresh-machine" / "model"
    assert (model / ".coach_checkpoint").read_text().startswith("1_Step-"), output[-4000:]
    assert (model / ".finished").is_file()
