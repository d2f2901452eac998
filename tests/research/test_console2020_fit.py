"""The 2019 generation's one log (the console's 2020 evaluation, 16 columns): read as episodes, and the car fitted on
it replays it closer than the other profiles."""

from __future__ import annotations

import numpy as np

from benchmarks.fidelity.simtrace_replay import CarReplay, replay_errors
from racer.shared.sim.car.dynamics import CAR_DYNAMICS
from research.console2020_fit.study import LOG, ROUTE, episode_segments


def test_the_16_column_log_reads_as_segments_named_by_episode():
    segments = episode_segments(LOG, 8)
    assert {segment.source for segment in segments} == {"episode 0", "episode 1", "episode 2"}
    assert len(segments) > 300 and max(segment.start_speed_mps for segment in segments) < 1.25


def test_the_console2020_car_replays_its_log_closer_than_gazebo_and_the_simtrace_fit():
    segments = episode_segments(LOG, 8)[::6]
    medians = {}
    for name in ("console2020-fit", "simtrace-fit", "gazebo"):
        replay = CarReplay(ROUTE, CAR_DYNAMICS[name])
        try:
            medians[name] = float(np.median([e.position_m[1.0] for e in replay_errors(replay, segments)]))
        finally:
            replay.close()
    assert medians["console2020-fit"] < 0.85 * medians["simtrace-fit"] < medians["gazebo"], medians
