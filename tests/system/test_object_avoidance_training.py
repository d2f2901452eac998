"""A short object-avoidance training through `racer train` (real Redis, real workers): it runs to its episode limit
and leaves no process behind, and its simtraces hold crashes, which `racer analyze` counts per episode and
iteration."""

from __future__ import annotations

import csv
import time

import pandas as pd
import pytest
from click.testing import CliRunner

from racer.analysis.cli import analyze_command
from tests.system.test_local_run import processes_mentioning, racer_train, small_custom_files  # noqa: F401

pytestmark = [pytest.mark.slow, pytest.mark.heavy]  # trainers and workers as processes


def test_object_avoidance_training_writes_crashes_that_the_analysis_counts(tmp_path, small_custom_files):  # noqa: F811
    # Boxes on both lanes 6 % of the lap from the line block the road: the second start (5 %) is right behind them.
    process = racer_train(
        tmp_path,
        small_custom_files,
        "--max-episodes",
        "4",
        "--race-type",
        "object-avoidance",
        "--race-param",
        "OBJECT_POSITIONS=0.06,1;0.06,-1",
    )
    output, _ = process.communicate(timeout=600)
    assert process.returncode == 0, output[-4000:]
    assert "iteration   0" in output and "iteration   1" in output, output[-3000:]
    model = tmp_path / "store" / "local-model"
    assert (model / "model" / ".coach_checkpoint").read_text().startswith("2_Step-")  # 4 episodes, 2 per iteration
    assert (model / "model" / ".finished").is_file()
    time.sleep(1)
    assert processes_mentioning(str(tmp_path)) == []
    rows = []
    for path in sorted(model.glob("*/training-simtrace/*-iteration.csv")):
        with path.open() as handle:
            rows += list(csv.DictReader(handle))
    assert rows and set(rows[0]) >= {"obstacle_crash_counter", "episode_status"}
    crashed = [row for row in rows if row["episode_status"] == "crashed"]
    assert crashed and all(row["done"] == "True" for row in crashed)  # training: NUMBER_OF_RESETS 0
    assert "OBJECT_POSITIONS" in (model / "training_params.yaml").read_text()

    out = tmp_path / "report"
    result = CliRunner().invoke(analyze_command, [str(model), "--no-pictures", "--out", str(out)])
    assert result.exit_code == 0, result.output
    iterations = pd.read_csv(out / "iterations.csv")
    assert iterations["crashes"].sum() == len(crashed)
