"""The yaw-inertia profile of the tyre fit (research/tyre_fit/inertia_profile.py): the inertia stays where it is
held, the other constants are refitted around it, and held-out rows need files to hold out."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from click.testing import CliRunner

from benchmarks.fidelity.simtrace_replay import load_segments
from research.tyre_fit import inertia_profile as profile
from research.tyre_fit import twin
from research.tyre_fit.study import tyre_fit_command
from research.tyre_fit.twin import CarConstants, SegmentBatch, loss


@pytest.fixture(scope="module")
def two_files(deepracer_data):
    names = ("drfc1_evaluation_0-iteration.csv", "console2022_evaluation_0-iteration.csv")
    return SegmentBatch.of([s for name in names for s in load_segments([deepracer_data / "simtrace" / name])[:4]])


def test_the_held_inertia_is_kept_and_the_rest_refitted(two_files, monkeypatch):
    held_values = []
    real_fit = profile.fit

    def recording_fit(batch, start, evaluations, progress=False, fixed=()):
        fitted = real_fit(batch, start, evaluations, progress, fixed)
        held_values.append(fitted.yaw_inertia_kgm2)
        return fitted

    monkeypatch.setattr(profile, "fit", recording_fit)
    monkeypatch.setattr(twin, "fit", recording_fit)  # the held-out folds fit through twin.leave_one_file_out
    rows = profile.inertia_profile(two_files, [0.2], evaluations=60, held_out_evaluations=40)
    assert held_values == [0.2, 0.2, 0.2]  # in sample, then one fold per file
    start = replace(CarConstants(), yaw_inertia_kgm2=0.2)
    assert rows[0]["loss_in_sample"] <= round(loss(two_files, start), 4)
    assert rows[0]["loss_held_out"] > 0
    assert 0 < rows[0]["median_position_error_1s_cm_held_out"] < 100


def test_held_out_errors_cover_every_segment_once(two_files):
    _, errors = profile.held_out_errors(two_files, 0.3, evaluations=20)
    assert errors.shape == (len(two_files.sources),)
    assert np.isfinite(errors).all()


def test_a_held_out_profile_of_one_file_is_refused(deepracer_data):
    path = deepracer_data / "simtrace" / "drfc1_evaluation_0-iteration.csv"
    route = deepracer_data / "routes" / "reinvent_base.npy"
    result = CliRunner().invoke(
        tyre_fit_command,
        [
            "--simtraces",
            str(path),
            "--route",
            str(route),
            "--fit",
            "leave-one-file-out",
            "--yaw-inertia-profile",
            "0.2",
        ],
    )
    assert result.exit_code != 0
    assert "at least two files" in result.output and path.name in result.output
