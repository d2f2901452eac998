"""Two short real training runs in one store (`racer train` end to end), trained once for the compare tests: a
baseline, and one with another reward function, more epochs and a longer episode limit."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.browser import chromium
from tests.conftest import write_custom_files
from tests.short_runs import CENTRE_REWARD, set_hyperparameters, train_short_run

BASELINE = "baseline"
CENTRE = "centre-reward"


@pytest.fixture(scope="session")
def two_short_runs(tmp_path_factory) -> tuple[Path, Path]:
    """The two runs' model folders (store/baseline, store/centre-reward)."""
    root = tmp_path_factory.mktemp("compare-runs")
    store = root / "store"
    baseline = write_custom_files(root / "baseline-files")
    centre = write_custom_files(root / "centre-files", reward_source=CENTRE_REWARD)
    set_hyperparameters(centre, num_epochs=5)
    first = train_short_run(store, root, BASELINE, baseline, "--max-episodes", "4")
    second = train_short_run(store, root, CENTRE, centre, "--max-episodes", "6")
    return first, second


@pytest.fixture
def browser():
    """A headless chromium (tests.browser)."""
    yield from chromium(window="1400,1000")
