"""A real `racer evaluate` run (scripted driver, two continuous laps on racer_oval) analysed against the car's
racing line: the lap times are the EvaluationMetrics', the section losses add up, the corners are where the line
bends past the threshold. The line is racer.racing_line's at one coarse control spacing (seconds, not a minute)."""

from __future__ import annotations

import csv
import functools
import json
import math

import numpy as np
import pandas as pd
import pytest

from racer.analysis.line_comparison import corner_curvature_per_m
from racer.analysis.pipeline import analyze
from racer.analysis.run_line import LineBook
from racer.compare.page import write_compare_page
from racer.compare.runs import load_runs
from racer.evaluation_worker.config import DeepRacerRules, EvaluationConfig, VideoOptions
from racer.evaluation_worker.runner import EvaluationSession
from racer.racing_line import racing_line
from racer.shared.sim.config import STEPS_PER_SECOND
from racer.shared.store import LocalStore
from racer.viewer.run_reader import RunLocation, RunReader
from tests.evaluation.scripted import CONTINUOUS_METADATA, ScriptedPolicy

MODEL = "scripted-model"
STEP_S = 1.0 / STEPS_PER_SECOND
SUM_TOLERANCE_S = 1e-6
"""The section losses telescope: their sum differs from lap - line only by floating-point rounding."""


@pytest.fixture(scope="module")
def evaluation(tmp_path_factory):
    """(model folder, the run's folder name): two continuous laps, the first from a standing start."""
    root = tmp_path_factory.mktemp("line-eval")
    config = EvaluationConfig(
        model_prefix=MODEL,
        track="racer_oval",
        deepracer=DeepRacerRules(number_of_trials=2, is_continuous=True),
        video=VideoOptions(enabled=False),
        mcap=False,
    )
    policy = ScriptedPolicy(speed_mps=2.5)
    session = EvaluationSession(LocalStore(root), config, policy=policy, model_metadata=CONTINUOUS_METADATA)
    policy.attach(session.driver)
    report = session.run()
    return root / MODEL, report.layout.run_name


@pytest.fixture(scope="module")
def book() -> LineBook:
    """racer.racing_line at one coarse control spacing: the same optimiser, seconds instead of a minute."""
    return LineBook(functools.partial(racing_line, spacing_m=0.2, control_spacings_m=(0.8,)))


@pytest.fixture(scope="module")
def analysed(evaluation, book, tmp_path_factory):
    folder, _ = evaluation
    out = tmp_path_factory.mktemp("line-report")
    return analyze(str(folder), out, sections=6, show_progress=False, lines=book), out


def test_lap_times_are_the_evaluation_metrics(evaluation, analysed):
    folder, run = evaluation
    analysis, out = analysed
    metrics = json.loads(next((folder / "metrics/evaluation").glob("*.json")).read_text())["metrics"]
    with open(folder / run / "evaluation-simtrace/0-iteration.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    laps = pd.read_csv(out / "evaluation_laps.csv")
    assert list(laps["time_from"]) == ["EvaluationMetrics", "EvaluationMetrics"]
    for lap, logged in zip(laps.itertuples(), metrics, strict=True):
        assert lap.lap_time_s == pytest.approx(logged["elapsed_time_in_milliseconds"] / 1000, abs=1e-9)
        mine = [float(r["tstamp"]) for r in rows if int(r["episode"]) == lap.lap - 1]
        previous_end = 0.0 if lap.lap == 1 else max(float(r["tstamp"]) for r in rows if int(r["episode"]) == 0)
        span = mine[-1] - (mine[0] if lap.lap == 1 else previous_end)  # lap 1 starts at its prepare row
        assert lap.simtrace_time_s == pytest.approx(span, abs=1e-9)
    # The standing start: the metrics count the prepare step, the simtrace's span does not; the next lap agrees.
    assert laps.loc[0, "lap_time_s"] - laps.loc[0, "simtrace_time_s"] == pytest.approx(STEP_S, abs=1e-3)
    assert laps.loc[1, "lap_time_s"] == pytest.approx(laps.loc[1, "simtrace_time_s"], abs=1e-3)
    against = pd.read_csv(out / "laps_against_line.csv")
    assert list(against["lap_time_s"]) == pytest.approx(list(laps["lap_time_s"]))
    html = (out / "report.html").read_text()
    assert f"{laps.loc[0, 'lap_time_s']:.3f}" in html and "Laps against the line" in html


def test_section_losses_add_up_to_the_lap_against_the_line(evaluation, analysed):
    folder, run = evaluation
    analysis, _ = analysed
    comparison = analysis.line_comparison
    assert len(comparison.laps) == 2
    with open(folder / run / "evaluation-simtrace/0-iteration.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    for lap in comparison.laps:
        sections = lap.stretches[lap.stretches["kind"] == "section"]
        assert len(sections) == 6
        assert sections["loss_s"].sum() == pytest.approx(lap.lap_time_s - lap.line_lap_s, abs=SUM_TOLERANCE_S)
        assert sections["line_s"].sum() == pytest.approx(lap.line_lap_s, abs=SUM_TOLERANCE_S)
        assert lap.ratio == pytest.approx(lap.lap_time_s / lap.line_lap_s, abs=1e-3) and lap.ratio > 1.0
        # Each interior section boundary against the simtrace's own progress: the lap's clock there is within two
        # steps of when progress passed that share of the centre line (a different projection, so not exact).
        mine = [r for r in rows if int(r["episode"]) == lap.lap - 1]
        end = float(mine[-1]["tstamp"])
        for number in range(1, 6):
            crossing = next(float(r["tstamp"]) for r in mine if float(r["progress"]) >= 100 * number / 6)
            clock_at = lap.clock.time_at(sections.iloc[number]["start_m"]) + end - lap.lap_time_s
            assert abs(clock_at - crossing) < 2 * STEP_S, (lap.lap, number, clock_at, crossing)


def test_corners_are_where_the_line_bends_past_the_threshold(analysed):
    analysis, _ = analysed
    lap = analysis.line_comparison.laps[0]
    limits = lap.car.limits
    threshold = corner_curvature_per_m(limits)
    slower = limits.top_speed_mps - limits.drive_accel_mps2 / STEPS_PER_SECOND
    assert threshold == pytest.approx(limits.lateral_accel_mps2 / slower**2)
    points = lap.stations.line.points_m
    before, after = points - np.roll(points, 1, axis=0), np.roll(points, -1, axis=0) - points
    cross = before[:, 0] * after[:, 1] - before[:, 1] * after[:, 0]
    turning = np.arctan2(cross, np.einsum("ij,ij->i", before, after))
    curvature = np.abs(turning) / (0.5 * (np.linalg.norm(before, axis=1) + np.linalg.norm(after, axis=1)))
    distance = lap.stations.distance_m[:-1]
    corners = lap.stretches[lap.stretches["kind"] == "corner"]
    assert len(corners) == 2  # an oval: its two ends
    inside = np.zeros(len(points), dtype=bool)
    for row in corners.itertuples():
        inside |= (
            (distance >= row.start_m) & (distance < row.end_m)
            if row.end_m >= row.start_m
            else (distance >= row.start_m) | (distance < row.end_m)
        )
    clear = np.abs(curvature - threshold) > 0.05 * threshold  # the turning-angle estimate differs at the edges
    assert np.array_equal(inside[clear], curvature[clear] > threshold)
    assert (corners["loss_s"] > -1.0).all() and math.isfinite(corners["loss_s"].sum())


def test_the_picture_is_in_the_report(analysed):
    analysis, out = analysed
    assert analysis.pictures["best_lap_over_line"].is_file()
    html = (out / "report.html").read_text()
    assert "The best evaluation lap over the racing line" in html and "Time lost per corner" in html


def test_a_simtrace_without_its_settings_gets_a_note_not_a_line(evaluation, book, tmp_path):
    folder, run = evaluation
    lone = folder / run / "evaluation-simtrace/0-iteration.csv"
    analysis = analyze(str(lone), tmp_path, track="racer_oval", pictures=False, show_progress=False, lines=book)
    assert analysis.line_comparison is not None and not analysis.line_comparison.laps
    assert any("no evaluation_params.yaml" in note for note in analysis.notes)
    assert any("simtrace's span" in note for note in analysis.notes)
    assert not (tmp_path / "laps_against_line.csv").exists()


def test_racer_compare_gives_the_best_lap_its_ratio(evaluation, analysed, book, tmp_path):
    """`racer compare`'s best lap (the live viewer's, racer.viewer.laps) against the same line: its car from the evaluation's params."""
    folder, run = evaluation
    analysis, _ = analysed
    compared = load_runs([str(folder), str(folder)], lines=book)
    bound = compared[0].bound
    line = analysis.line_comparison.laps[0].stations.line
    assert compared[0].best_lap["run"] == run
    # The viewer's best lap is timed as the report times it: the EvaluationMetrics' lap, not the simtrace's span.
    assert compared[0].best_lap["lap_time_s"] == pytest.approx(analysis.evaluation_laps["lap_time_s"].min(), abs=1e-3)
    assert bound["line_lap_s"] == pytest.approx(line.lap_time_s, abs=1e-3)
    assert bound["ratio"] == pytest.approx(compared[0].best_lap["lap_time_s"] / line.lap_time_s, abs=1e-3)
    page = write_compare_page(compared, tmp_path / "compare.html").read_text()
    assert "ratio to the lap-time bound" in page and f"{bound['ratio']:.3f}" in page


def test_the_viewer_gives_its_best_lap_the_ratio_without_waiting(evaluation, book):
    """The first poll answers at once (the line is computed in a thread); a later one has the ratio."""
    folder, run = evaluation
    reader = RunReader(RunLocation(LocalStore(folder.parent), folder.name), lines=book)
    first = reader.progress()
    assert first["best_lap"]["run"] == run and first["best_lap"]["complete"]
    reader._bounding.join(timeout=120)
    bound = reader.progress()["best_lap_bound"]
    assert bound["ratio"] == pytest.approx(first["best_lap"]["lap_time_s"] / bound["line_lap_s"], abs=1e-3)
    assert "racer_oval" in bound["line"]
