"""What the real logs allow the replay: their row-timing noise and the error of an exact car model on a pseudo-log."""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks.fidelity.simtrace_replay import load_segments
from research.replay_limits.noise import in_progress_rows, oracle_start_errors_m, replay_floor_m, row_timing
from research.tyre_fit.twin import CarConstants, SegmentBatch, position_errors_m, simulate


def _synthetic_episode(tstamp_noise_s: float, seed: int) -> tuple[np.ndarray, ...]:
    """A car at 1 m/s whose true step lengths vary; pose k holds at tstamp[k-1] as in the SimApp's rows."""
    rng = np.random.default_rng(seed)
    true_steps = 1 / 15 + rng.normal(0.0, 0.005, 200)
    true_times = np.concatenate([[0.0], np.cumsum(true_steps)])
    x = true_times[:-1].copy()  # pose k at true time k-1 (speed 1 m/s along x)
    tstamp = true_times[1:] + rng.normal(0.0, tstamp_noise_s, 200) if tstamp_noise_s else true_times[1:]
    return x, np.zeros_like(x), tstamp, np.ones_like(x)


def test_row_timing_tells_true_step_lengths_from_noisy_stamps():
    exact = row_timing([_synthetic_episode(0.0, seed) for seed in range(3)])
    assert exact.tstamp_share == pytest.approx(1.0, abs=0.05)
    assert exact.unexplained_jitter_s < 0.001
    # Stamps with 5 ms of their own noise explain about half of the 5 ms of true step-length variation.
    noisy = row_timing([_synthetic_episode(0.005, seed) for seed in range(3)])
    assert 0.2 < noisy.tstamp_share < 0.7
    assert 0.002 < noisy.unexplained_jitter_s < 0.008
    assert noisy.step_s == pytest.approx(1 / 15, rel=0.02)


def test_real_tstamps_explain_little_of_the_rows_spread(deepracer_data):
    folder = deepracer_data / "simtrace"
    timing = row_timing(
        in_progress_rows(
            [folder / "console2022_evaluation_0-iteration.csv", folder / "drfc1_evaluation_0-iteration.csv"]
        )
    )
    assert timing.rows > 300
    assert timing.step_s == pytest.approx(1 / 15, rel=0.03)
    # README: at a held speed the logged step lengths carry ≈ 5-20 % of the distance's spread; the rest is ≈ 4 ms.
    assert 0.0 < timing.tstamp_share < 0.4
    assert 0.002 < timing.unexplained_jitter_s < 0.007
    with pytest.raises(ValueError, match="held speed command"):
        row_timing(in_progress_rows([folder / "drfc3_worker1_training_0-iteration.csv"]))


def test_exact_model_floor_is_small_and_grows_with_jitter(deepracer_data):
    segments = load_segments([deepracer_data / "simtrace" / "drfc1_evaluation_0-iteration.csv"])
    exact = np.median(replay_floor_m(segments, CarConstants(), 0.0))
    jittered = np.median(replay_floor_m(segments, CarConstants(), 0.005))
    assert 0.0 < exact < 0.03 and exact < jittered < 0.06
    # racer's car on the real log misses by far more than the floor: the logs' noise is not what limits it.
    batch = SegmentBatch.of(segments)
    xs, ys, _ = simulate(batch, CarConstants())
    assert np.median(position_errors_m(batch, xs, ys, 1.0)) > 2 * jittered


def test_an_oracle_start_state_gains_little(deepracer_data):
    segments = load_segments([deepracer_data / "simtrace" / "drfc1_evaluation_0-iteration.csv"])
    batch = SegmentBatch.of(segments)
    xs, ys, _ = simulate(batch, CarConstants())
    plain = np.median(position_errors_m(batch, xs, ys, 1.0))
    near = oracle_start_errors_m(segments, CarConstants(), fit_rows=8, horizon_s=0.5)
    oracle = oracle_start_errors_m(segments, CarConstants(), fit_rows=8)
    # Fitted to the poses up to ≈ 0.5 s, the start state brings the twin close there ...
    assert np.median(near) < 0.03
    # ... and helps after 1 s, but the car still misses by centimetres: the error grows after the start.
    assert np.median(oracle) < plain and np.median(oracle) > 0.04


def test_the_study_prints_each_limit_per_band_below_the_replays_error(deepracer_data):
    """The limits of a car model on these logs lie under what racer's fitted car reaches in `python -m benchmarks fidelity`."""
    from benchmarks.fidelity.simtrace_replay import run_fidelity
    from research.replay_limits.study import run_limits

    paths = [deepracer_data / "simtrace" / "drfc1_evaluation_0-iteration.csv"]
    limits = run_limits(paths)
    replayed = run_fidelity(paths, deepracer_data / "routes" / "reinvent_base.npy")["bands"]
    assert limits["files"] == 1 and limits["segments"] >= 5
    assert limits["row_timing"]["rows"] > 20 and 0 < limits["row_timing"]["unexplained_jitter_s"] < 0.01
    assert limits["heading_floor_deg_1s_median"] == {}  # one file: nothing to fit the predictor on
    assert limits["replay_floor_m_1s_median"] and set(limits["replay_floor_m_1s_median"]) == set(
        limits["oracle_start_m_1s_median"]
    )
    for band, floor in limits["replay_floor_m_1s_median"].items():
        # An exact twin on its own pseudo-log (the logs' timing noise, the replay's protocol) misses by less.
        assert 0 < floor < replayed[band]["position_m_1s_median"]
        assert 0 < limits["oracle_start_m_1s_median"][band]
