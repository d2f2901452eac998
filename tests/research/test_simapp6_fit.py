"""The simapp6 car fitted on DeepRacer on AWS's 2026 logs (research/simapp6_fit/): the shipped car replays them
within the goal where the car built from the files alone does not, the fit keeps the source's facts fixed, and
leaving one file out needs files to leave out."""

from __future__ import annotations

import pytest
from click.testing import CliRunner

from benchmarks.fidelity.simtrace_replay import load_segments, run_fidelity
from research.simapp6_fit.study import FIXED_FACTS, LOSS_HORIZONS_S, START, simapp6_fit_command
from research.tyre_fit.twin import SegmentBatch, fit

SPAIN_FILES = ("training_0", "training_1", "evaluation_0")


@pytest.fixture(scope="module")
def spain(deepracer_data):
    files = [deepracer_data / "simtrace" / f"droa2026_spain_{name}-iteration.csv" for name in SPAIN_FILES]
    return files, deepracer_data / "simapp-routes" / "Spain_track.npy"


def test_the_simapp6_car_replays_the_2026_logs_within_0_15_m_and_the_source_built_car_does_not(spain):
    """`python -m benchmarks fidelity`'s 2 s segments, median position error after 1 s per band with >= 30 segments."""
    files, route = spain
    for car, within in (("simapp6-fit", True), ("simapp6-ros2", False)):
        bands = run_fidelity(files, route, car=car)["bands"]
        judged = [entry["position_m_1s_median"] for entry in bands.values() if entry["segments"] >= 30]
        assert len(judged) == 2 and all(error <= 0.15 for error in judged) is within, (car, judged)


def test_segments_every_few_rows_and_the_fit_keeps_the_fixed_constants(spain):
    files, _ = spain
    every_eighth = load_segments(files[1:2], 1.0)
    every_fourth = load_segments(files[1:2], 1.0, stride_rows=4)
    assert len(every_fourth) > len(every_eighth) > 0
    assert {(s.episode, float(s.times_s[0])) for s in every_eighth} <= {
        (s.episode, float(s.times_s[0])) for s in every_fourth
    }
    fitted = fit(SegmentBatch.of(every_fourth[:12]), START, 60, fixed=FIXED_FACTS, horizons_s=LOSS_HORIZONS_S)
    for name in FIXED_FACTS:
        assert getattr(fitted.tyres, name) == getattr(START.tyres, name)
    assert fitted.as_dict() != START.as_dict()


def test_one_file_cannot_be_left_out(spain, tmp_path):
    files, route = spain
    (tmp_path / files[2].name).write_bytes(files[2].read_bytes())
    result = CliRunner().invoke(simapp6_fit_command, ["--simtraces", str(tmp_path), "--route", str(route)])
    assert result.exit_code == 1 and "leaving one file out needs two or more files" in result.output
