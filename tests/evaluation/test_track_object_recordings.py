"""Evaluations with obstacles and bot cars: the MCAP carries their poses per step, the three videos show them."""

from __future__ import annotations

import json
import math

import imageio.v2 as imageio
import numpy as np
from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory

from racer.evaluation_worker.config import DeepRacerRules, EvaluationConfig, VideoOptions
from racer.evaluation_worker.runner import EvaluationSession
from racer.evaluation_worker.video import VIEWS
from racer.shared.sim.objects.bodies import BOX_HEIGHT_M, BOX_LENGTH_M, BOX_WIDTH_M
from racer.shared.sim.objects.challenge import ChallengeConfig, ObjectPosition
from racer.shared.sim.tracks.track import Track
from racer.shared.store import LocalStore
from tests.evaluation.conftest import simtrace_of
from tests.evaluation.scripted import CONTINUOUS_METADATA, ScriptedPolicy

BOX = ChallengeConfig(race_type="OBJECT_AVOIDANCE", object_positions=(ObjectPosition(0.2, 1),))
BOT = ChallengeConfig(race_type="HEAD_TO_BOT", number_of_bot_cars=1, bot_car_speed_mps=0.5)


def _evaluate(root, challenge, *, video: bool):
    config = EvaluationConfig(
        model_prefix="race-model",
        track="racer_oval",
        deepracer=DeepRacerRules(number_of_trials=1, number_of_resets=0),
        challenge=challenge,
        video=VideoOptions(width_px=160, height_px=120) if video else VideoOptions(enabled=False),
        mcap=True,
    )
    policy = ScriptedPolicy(1.0)
    session = EvaluationSession(LocalStore(root), config, policy=policy, model_metadata=CONTINUOUS_METADATA)
    policy.attach(session.driver)
    return session.run()


def _messages(path, topic):
    with path.open("rb") as handle:
        return [
            (message.log_time, decoded)
            for _, _, message, decoded in make_reader(
                handle, decoder_factories=[DecoderFactory()]
            ).iter_decoded_messages(topics=[topic])
        ]


def _json(path, topic):
    with path.open("rb") as handle:
        return [json.loads(message.data) for _, _, message in make_reader(handle).iter_messages(topics=[topic])]


def _brown(frame: np.ndarray) -> np.ndarray:
    """Pixels of the box's brown (#7b614f, darker on its shaded faces) after H.264."""
    r, g, b = (frame[:, :, i].astype(int) for i in range(3))
    return (r - b > 12) & (r > g) & (g > b) & (r < 190)


def test_an_obstacle_run_records_the_box_in_the_mcap_and_all_three_videos(tmp_path):
    report = _evaluate(tmp_path, BOX, video=True)
    rows = simtrace_of(tmp_path, report)
    steps = len(rows)
    assert rows.episode_status.iloc[-1] == "crashed"  # the scripted car follows the centre line into the box
    assert report.mcap_messages["/objects"] == report.mcap_messages["/objects/poses"] == steps

    mcap = tmp_path / report.keys["mcap"]
    track = Track.load("racer_oval")
    x, y, yaw = track.pose_at(0.2, "inner")
    poses = _json(mcap, "/objects/poses")
    assert all(p["objects"] == poses[0]["objects"] for p in poses)  # a static box
    (box,) = poses[0]["objects"]
    assert box["name"] == "obstacle_0" and box["kind"] == "box_obstacle"
    assert (box["x_m"], box["y_m"], box["yaw_rad"]) == (x, y, yaw)
    time_ns, scene = _messages(mcap, "/objects")[0]
    assert time_ns == round(rows.tstamp.iloc[0] * 1e9)
    (entity,) = scene.entities
    assert entity.id == "objects/obstacle_0" and entity.frame_id == "track"
    (cube,) = entity.cubes
    assert (cube.size.x, cube.size.y, cube.size.z) == (BOX_LENGTH_M, BOX_WIDTH_M, BOX_HEIGHT_M)
    assert (cube.pose.position.x, cube.pose.position.y) == (x, y)
    assert 2 * math.atan2(cube.pose.orientation.z, cube.pose.orientation.w) == yaw

    # Shortly before the crash the box fills part of every view (in-car, follow camera, top view).
    for view in VIEWS:
        reader = imageio.get_reader(str(tmp_path / report.keys[view]), format="ffmpeg")
        frames = [frame for frame in reader]
        reader.close()
        assert len(frames) == steps
        near, start = _brown(frames[-3]).sum(), _brown(frames[0]).sum()
        if view == "camera-topview":  # drawn on every frame, where it stands
            assert near > 20 and abs(near - start) < 10
        else:  # the box grows as the car comes close: 2 m away at the start, touching it at the end
            assert near > 3 * start > 150, f"{view}: {start} -> {near} box pixels"


def test_a_bot_car_run_records_the_bot_moving(tmp_path):
    report = _evaluate(tmp_path, BOT, video=False)
    rows = simtrace_of(tmp_path, report)
    poses = _json(tmp_path / report.keys["mcap"], "/objects/poses")
    assert len(poses) == len(rows) > 20
    first, last = poses[0]["objects"][0], poses[-1]["objects"][0]
    assert first["name"] == "bot_car_0" and first["kind"] == "bot_car" and first["speed_mps"] == 0.5
    elapsed_s = rows.tstamp.iloc[-1] - rows.tstamp.iloc[0]
    travelled_m = math.dist((first["x_m"], first["y_m"]), (last["x_m"], last["y_m"]))
    assert 0.3 * 0.5 * elapsed_s < travelled_m <= 0.5 * elapsed_s + 0.01  # along its lane (a chord on the curves)
