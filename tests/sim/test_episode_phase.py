"""`PhaseMachine` on its own (no MuJoCo): poses on racer_oval's centre line judged step by step."""

from __future__ import annotations

import math

import numpy as np
import pytest

from racer.shared.sim.car.vehicle import Car, CarPose
from racer.shared.sim.config import EnvConfig
from racer.shared.sim.episode.phase import PhaseMachine, StepVerdict
from racer.shared.sim.tracks.track import Track

STEP_S = 1.0 / 15


@pytest.fixture(scope="module")
def track() -> Track:
    return Track.load("racer_oval")


def _pose_at(track: Track, ndist: float, off_road: bool = False) -> CarPose:
    """The car's pose with its origin on the centre line at `ndist` (4 m to the side when `off_road`)."""
    x, y, yaw = track.pose_at(ndist)
    if off_road:
        x, y = x - 4.0 * math.sin(yaw), y + 4.0 * math.cos(yaw)
    front = (x + Car.FRONT_OF_CAR_M * math.cos(yaw), y + Car.FRONT_OF_CAR_M * math.sin(yaw))
    return CarPose(x, y, yaw, front, np.full(4, x), np.full(4, y))


def _judge(machine: PhaseMachine, track: Track, ndist: float, off_road: bool = False) -> StepVerdict:
    pose = _pose_at(track, ndist, off_road)
    geometry = track.point_geometry(*pose.model_point)
    return machine.judge(pose, geometry, all_on=not off_road, any_on=not off_road, objects_time_s=0.0)


def test_prepare_then_run_then_a_lap(track):
    machine = PhaseMachine(EnvConfig(), None, track, 0.0)
    prepare = _judge(machine, track, 0.0)
    assert (prepare.status, prepare.run_step, prepare.drives, prepare.hold_pose) == ("prepare", False, False, None)
    verdicts = [_judge(machine, track, ndist) for ndist in (0.3, 0.6, 0.9, 0.995)]
    assert [v.status for v in verdicts] == ["in_progress"] * 3 + ["lap_complete"]
    assert all(v.run_step and v.drives for v in verdicts[:3])
    assert verdicts[-1].terminated and verdicts[-1].progress == 100


def test_off_track_with_a_reset_left_pauses_holds_the_car_and_counts_the_penalty_down(track):
    machine = PhaseMachine(EnvConfig(number_of_resets=1, off_track_penalty_s=0.1), None, track, 0.0)
    _judge(machine, track, 0.0)
    _judge(machine, track, 0.25)
    off = _judge(machine, track, 0.3, off_road=True)
    assert (off.status, off.terminated, off.drives, off.run_step) == ("off_track", False, False, True)
    assert off.pause_duration_s == 0.1 and off.hold_pose is not None
    # Put back at the previous step's progress (its front of car: 25 % of the lap + 0.14 m), on a lane.
    spot_ndist = track.project_normalized(*off.hold_pose[:2])
    assert spot_ndist == pytest.approx(0.25 + Car.FRONT_OF_CAR_M / track.length_m, abs=0.002)
    assert track.distance_from_center(*off.hold_pose[:2]) > 0.05
    pauses = [_judge(machine, track, spot_ndist) for _ in range(2)]
    assert [p.status for p in pauses] == ["pause", "pause"]
    assert [p.pause_duration_s for p in pauses] == pytest.approx([0.1 - STEP_S, 0.1 - 2 * STEP_S])
    assert pauses[0].hold_pose == off.hold_pose and pauses[1].hold_pose is None  # the last pause step lets go
    assert not any(p.drives or p.run_step for p in pauses)
    again = _judge(machine, track, spot_ndist + 0.01)
    assert again.status == "in_progress" and again.drives
    # No reset left: the next off-track ends the episode, with no penalty on its row.
    last = _judge(machine, track, 0.4, off_road=True)
    assert (last.status, last.terminated, last.pause_duration_s, last.hold_pose) == ("off_track", True, 0.0, None)


def test_a_new_episode_and_a_renewed_reset_budget(track):
    machine = PhaseMachine(EnvConfig(number_of_resets=1), None, track, 0.0)
    _judge(machine, track, 0.0)
    assert _judge(machine, track, 0.2, off_road=True).status == "off_track"  # uses the one reset
    machine.continue_after_lap((0.0, 0.0), renew_reset_budget=True)
    for _ in range(40):
        if _judge(machine, track, 0.2).status != "pause":
            break
    assert not _judge(machine, track, 0.22, off_road=True).terminated  # the budget was renewed
    machine.start(track.reversed(), 0.5)
    assert machine.start_ndist == 0.5 and _judge(machine, track.reversed(), 0.5).status == "prepare"
