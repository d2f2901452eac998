"""research/tyre_fit's hypotheses: the replay's reading of the logs varied with the fit's twin."""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner

from benchmarks.fidelity.simtrace_replay import SPEED_BANDS_MPS, band_label, load_segments
from research.tyre_fit.hypotheses import VARIANTS, screen, step_lengths
from research.tyre_fit.study import tyre_fit_command
from research.tyre_fit.twin import CarConstants, SegmentBatch, position_errors_m, simulate


@pytest.fixture(scope="module")
def segments(deepracer_data):
    folder = deepracer_data / "simtrace"
    return load_segments(
        [folder / "drfc1_evaluation_0-iteration.csv", folder / "console2022_evaluation_0-iteration.csv"]
    )


def test_time_bases(segments):
    batch = SegmentBatch.of(segments)
    replayed = batch.step_s > 0  # the rest is padding of the shorter segments
    assert np.all(step_lengths(batch, "nominal")[replayed] == pytest.approx(1 / 15))
    logged = step_lengths(batch, "tstamp")
    for row, segment in zip(logged, segments, strict=True):
        assert np.array_equal(row[: len(segment.times_s) - 1], np.diff(segment.times_s))
    # The logged steps jitter around the nominal one; each segment's median is one number.
    assert 0.003 < float(np.std(logged[replayed])) < 0.02
    median = step_lengths(batch, "median")
    assert np.all(median[replayed] == np.repeat(median[:, 2:3], median.shape[1], axis=1)[replayed])
    with pytest.raises(ValueError, match="unknown time base 'wall'"):
        step_lengths(batch, "wall")


def test_a_late_command_replays_worse_and_the_plain_variant_is_the_replay(segments):
    table = screen(segments, SPEED_BANDS_MPS, band_label)
    assert set(VARIANTS) < set(table)
    batch = SegmentBatch.of(segments)
    xs, ys, _ = simulate(batch, CarConstants())
    plain = float(np.median(position_errors_m(batch, xs, ys, 1.0)[[s.start_speed_mps < 0.75 for s in segments]]))
    assert table["as replayed"]["position_m_1s_median"]["0-0.75 m/s"] == pytest.approx(plain, abs=1e-4)
    # In the SimApp a row's action acts from that row's pose on: delaying it by a row makes every figure worse.
    assert table["command 1 row late"]["loss_m"] > 1.15 * table["as replayed"]["loss_m"]
    assert table["start: backward differences"]["loss_m"] > table["as replayed"]["loss_m"]


def test_the_study_prints_the_hypotheses(deepracer_data):
    path = deepracer_data / "simtrace" / "drfc1_evaluation_0-iteration.csv"
    route = deepracer_data / "routes" / "reinvent_base.npy"
    result = CliRunner().invoke(tyre_fit_command, ["--simtraces", str(path), "--route", str(route), "--hypotheses"])
    assert result.exit_code == 0, result.output
    numbers = json.loads(result.stdout.strip().splitlines()[-1])
    assert numbers["files"] == 1 and "time base: logged tstamps" in numbers["hypotheses"]
