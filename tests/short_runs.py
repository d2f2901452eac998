"""Short real training runs (`racer train` end to end, two workers, a few episodes) for tests that need finished runs
in a store: the compare page, the viewer's run list. tests/conftest.py's session fixture `two_short_runs` trains
the two runs of `train_two_short_runs` once for both (`shared_short_runs`, across pytest-xdist workers)."""

from __future__ import annotations

import fcntl
import json
import os
import subprocess
import sys
from pathlib import Path

from tests.conftest import write_custom_files

CENTRE_REWARD = '''def reward_function(params):
    """Stay near the centre line."""
    half_width = 0.5 * params["track_width"]
    return max(1e-3, 1.0 - params["distance_from_center"] / half_width)
'''


def train_env(store: Path) -> dict[str, str]:
    return dict(os.environ, RACER_STORE=str(store), MUJOCO_GL=os.environ.get("MUJOCO_GL", "egl"))


def train_args(custom_files: Path, model: str, *args: str) -> list[str]:
    return [
        sys.executable,
        "-m",
        "racer.cli",
        "train",
        "--custom-files",
        str(custom_files),
        "--workers",
        "2",
        "--worlds",
        "base,wood",
        "--model-prefix",
        model,
        *args,
    ]


def train_short_run(store: Path, workdir: Path, model: str, custom_files: Path, *args: str) -> Path:
    """Train `model` into the local store `store` to the end (`args`: its limit, e.g. --max-episodes 4); its folder."""
    result = subprocess.run(
        train_args(custom_files, model, "--viewer-port", "0", *args),
        capture_output=True,
        text=True,
        env=train_env(store),
        cwd=workdir,
        timeout=600,
    )
    assert result.returncode == 0, (result.stdout + result.stderr)[-4000:]
    return store / model


def set_hyperparameters(custom_files: Path, **values: object) -> None:
    path = custom_files / "hyperparameters.json"
    path.write_text(json.dumps({**json.loads(path.read_text()), **values}))


BASELINE = "baseline"
CENTRE = "centre-reward"


def train_two_short_runs(root: Path) -> tuple[Path, Path]:
    """Two runs in one store, root/store: a baseline (4 episodes, 2 iterations), and one with another reward
    function, more epochs and a longer episode limit (6 episodes, 3 iterations); their model folders."""
    store = root / "store"
    baseline = write_custom_files(root / "baseline-files")
    centre = write_custom_files(root / "centre-files", reward_source=CENTRE_REWARD)
    set_hyperparameters(centre, num_epochs=5)
    first = train_short_run(store, root, BASELINE, baseline, "--max-episodes", "4")
    second = train_short_run(store, root, CENTRE, centre, "--max-episodes", "6")
    return first, second


def shared_short_runs(folder: Path) -> tuple[Path, Path]:
    """`train_two_short_runs` in folder/two-short-runs, once: a later caller, in this process or another, waits on
    the lock and gets the runs the first one trained."""
    root = folder / "two-short-runs"
    root.mkdir(exist_ok=True)
    with open(root / "lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # released when the file closes, and by the kernel if this process dies
        if not (root / "trained").exists():
            train_two_short_runs(root)
            (root / "trained").write_text("")
    return root / "store" / BASELINE, root / "store" / CENTRE
