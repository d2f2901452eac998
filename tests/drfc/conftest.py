"""DRfC experiment folders for the tests: DRfC's own templates (shared data) or a few lines of run.env."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.conftest import write_custom_files

TEMPLATE_KINDS = ("run", "system", "worker")


@pytest.fixture
def drfc_templates(deepracer_data: Path) -> dict[str, Path]:
    """DRfC 2eb1a1f1's defaults/template-{run,system,worker}.env, as the shared data holds them."""
    config = deepracer_data / "config"
    return {kind: config / f"drfc_defaults_template-{kind}.env" for kind in TEMPLATE_KINDS}


def write_experiment(
    folder: Path,
    run: str,
    system: str | None = None,
    workers: dict[int, str] | None = None,
    custom_files: bool = True,
) -> Path:
    """A DRfC experiment folder: run.env, optional system.env and worker-N.env, a small custom_files/."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "run.env").write_text(run)
    if system is not None:
        (folder / "system.env").write_text(system)
    for number, text in (workers or {}).items():
        (folder / f"worker-{number}.env").write_text(text)
    if custom_files:
        write_custom_files(folder / "custom_files", min_eval_trials=None)
    return folder
