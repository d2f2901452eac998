"""Without ../shared/deepracer-data, pytest stops before running anything, with one message naming the folder."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[2]


def test_a_checkout_without_the_shared_folder_gets_one_clear_error(tmp_path):
    checkout = tmp_path / "racer"  # no tmp_path / "shared" beside it
    (checkout / "tests").mkdir(parents=True)
    for name in ("conftest.py", "shared_data.py"):
        shutil.copy(REPO_ROOT / "tests" / name, checkout / "tests" / name)
    (checkout / "tests" / "test_needs_data.py").write_text(
        "def test_one(deepracer_data):\n    pass\n\n\ndef test_two(deepracer_data):\n    pass\n"
    )
    (checkout / "tests" / "test_no_data.py").write_text("def test_plain():\n    pass\n")
    environment = {**os.environ, "PYTHONPATH": str(checkout)}
    run = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "tests"],
        cwd=checkout,
        env=environment,
        capture_output=True,
        text=True,
        timeout=120,
    )
    output = run.stdout + run.stderr
    missing = tmp_path / "shared" / "deepracer-data"
    assert run.returncode == 4, output  # a usage error: nothing ran
    assert f"2 selected tests read real DeepRacer files from {missing}, which is missing" in output
    assert output.count("which is missing") == 1 and "FileNotFoundError" not in output

    plain = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "tests/test_no_data.py"],
        cwd=checkout,
        env=environment,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert plain.returncode == 0, plain.stdout + plain.stderr  # tests that don't need the data still run
