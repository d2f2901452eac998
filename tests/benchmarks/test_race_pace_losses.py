"""`python -m benchmarks race-pace --picture`: the drawn lap's losses to the bound's line per section and corner, with
`racer analyze`'s measure."""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks.race_pace_losses import SECTIONS, lap_against_line, loss_summary
from benchmarks.race_pace_picture import DrivenLap
from racer.analysis.line_comparison import LineStations
from racer.racing_line import CarLimits, racing_line
from racer.shared.sim.car.dynamics import CAR_DYNAMICS
from racer.shared.sim.config import STEPS_PER_SECOND
from racer.shared.sim.tracks.track import Track

SLOWER = 1.25
"""The synthetic lap drives the line itself, every stretch this much slower than the line's clock."""


@pytest.fixture(scope="module")
def oval():
    track = Track.load("racer_oval")
    return track, racing_line(track, CarLimits.of_car(CAR_DYNAMICS["gazebo"]), control_spacings_m=(0.8,))


def lap_on_the_line(line, slower: float) -> DrivenLap:
    """A flying lap along the line's own points, its clock the line's stretched by `slower`: 15 Hz simtrace rows."""
    stations = LineStations.of(line)
    lap_s = float(stations.time_s[-1]) * slower
    times = np.arange(1, int(np.ceil(lap_s * STEPS_PER_SECOND)) + 1) / STEPS_PER_SECOND
    times[-1] = lap_s
    distance = np.interp(times / slower, stations.time_s, stations.distance_m)
    closed = np.vstack((line.points_m, line.points_m[:1]))
    x, y = (np.interp(distance, stations.distance_m, closed[:, axis]) for axis in (0, 1))
    rows = tuple(
        {"X": x[i], "Y": y[i], "tstamp": 100.0 + times[i], "progress": 100.0 * distance[i] / stations.length_m,
         "episode_status": "lap_complete" if i == len(times) - 1 else "in_progress"}
        for i in range(len(times))
    )  # fmt: skip
    return DrivenLap("7.ckpt", 1, np.column_stack((x, y)), lap_s, 100.0, rows)


def test_a_lap_slower_everywhere_loses_in_every_stretch_in_proportion(oval, tmp_path):
    track, line = oval
    lap = lap_against_line(track, line, lap_on_the_line(line, SLOWER))
    summary = loss_summary(lap, tmp_path / "losses.png")
    assert summary["lap_s"] == pytest.approx(SLOWER * line.lap_time_s, abs=1e-3)
    assert summary["loss_s"] == pytest.approx((SLOWER - 1) * line.lap_time_s, abs=1e-3)
    assert len(summary["sections"]) == SECTIONS and summary["corners"]  # the oval's two bends at least
    for stretch in summary["sections"] + summary["corners"]:
        assert stretch["loss_s"] == pytest.approx((SLOWER - 1) * stretch["line_s"], abs=0.02), stretch
    assert sum(s["loss_s"] for s in summary["sections"]) == pytest.approx(summary["loss_s"], abs=0.01)
    in_corners = sum(s["loss_s"] for s in summary["corners"])
    assert summary["in_corners_s"] == pytest.approx(in_corners, abs=2e-3)
    assert summary["between_corners_s"] == pytest.approx(summary["loss_s"] - in_corners, abs=2e-3)
    losses = [s["loss_s"] for s in summary["costliest"]]
    assert losses == sorted(losses, reverse=True) and losses[0] == max(
        s["loss_s"] for s in summary["sections"] + summary["corners"]
    )
    assert (tmp_path / "losses.png").stat().st_size > 20_000


def test_a_lap_that_did_not_finish_has_no_losses(oval):
    track, line = oval
    unfinished = DrivenLap("7.ckpt", 0, np.zeros((3, 2)), None, 40.0, ())
    assert lap_against_line(track, line, unfinished) is None


def test_a_run_with_no_evaluation_in_time_draws_the_line_alone(oval, tmp_path):
    """Under load a short run's first evaluation may come after the limit: the picture is the bound alone, no losses."""
    from benchmarks.race_pace import _picture

    track, line = oval
    result = {"track": track.name, "generation": "simapp6", "car_profile": "simapp6-fit", "world": "base"}
    found = _picture(track, line, [], {"best_three_lap_average": None}, result, tmp_path / "pace.png", tmp_path, 0)
    assert found == {"picture": str(tmp_path / "pace.png")}
    assert (tmp_path / "pace.png").stat().st_size > 10_000 and not (tmp_path / "pace-losses.png").exists()
