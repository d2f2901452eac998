"""Videos, the MCAP recording, the summary and the store layout of one short scripted evaluation."""

from __future__ import annotations

import datetime as dt
import json

import imageio.v2 as imageio
import numpy as np
import pytest
from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory

from racer.evaluation_worker.config import DeepRacerRules, VideoOptions
from racer.evaluation_worker.video import VIEWS
from racer.shared.deepracer.training_params import parse_training_params
from tests.evaluation.conftest import run_scripted, simtrace_of

NOW = dt.datetime(2026, 11, 22, 7, 30, 5, tzinfo=dt.UTC)


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    root = tmp_path_factory.mktemp("store")
    out = tmp_path_factory.mktemp("out")
    report, _ = run_scripted(
        root,
        exits={0: [50.0]},
        deepracer=DeepRacerRules(number_of_trials=1, number_of_resets=2, off_track_penalty_s=0.4),
        video=VideoOptions(width_px=160, height_px=120),
        mcap=True,
        out_dir=out,
        now=NOW,
    )
    return root, out, report


def test_store_layout_follows_deepracer_for_cloud(recorded):
    root, out, report = recorded
    run = "scripted-model/evaluation-20261122073005"
    assert report.keys == {
        "metrics": "scripted-model/metrics/evaluation/evaluation-20261122073005.json",
        "simtrace": f"{run}/evaluation-simtrace/0-iteration.csv",
        "summary": f"{run}/summary.json",
        "params": f"{run}/evaluation_params.yaml",
        "camera-incar": f"{run}/camera-incar/0-video.mp4",
        "camera-topview": f"{run}/camera-topview/0-video.mp4",
        "camera-45degree": f"{run}/camera-45degree/0-video.mp4",
        "mcap": f"{run}/evaluation.mcap",
    }
    for key in report.keys.values():
        stored = (root / key).read_bytes()
        assert stored and stored == (out / key.removeprefix("scripted-model/")).read_bytes()


def test_videos_decode_with_one_frame_per_simtrace_row(recorded):
    root, _, report = recorded
    rows = simtrace_of(root, report)
    assert report.video_frames == {view: len(rows) for view in VIEWS}
    sizes = {"camera-incar": (240, 320), "camera-topview": (120, 160), "camera-45degree": (120, 160)}
    for view in VIEWS:
        reader = imageio.get_reader(str(root / report.keys[view]), format="ffmpeg")
        assert reader.get_meta_data()["fps"] == 15.0
        frames = [frame for frame in reader]
        reader.close()
        assert len(frames) == len(rows), view
        assert frames[0].shape == (*sizes[view], 3)
        assert np.std(frames[len(frames) // 2]) > 5.0, f"{view} is blank"


def test_top_view_draws_the_car_where_the_simtrace_puts_it(recorded):
    root, _, report = recorded
    rows = simtrace_of(root, report)
    reader = imageio.get_reader(str(root / report.keys["camera-topview"]), format="ffmpeg")
    frames = [frame for frame in reader]
    reader.close()
    reds = []
    for index in (10, len(rows) // 3, len(rows) - 5):
        frame = frames[index].astype(int)
        red = (frame[:, :, 0] > 150) & (frame[:, :, 1] < 90) & (frame[:, :, 2] < 90)
        ys, xs = np.nonzero(red)
        assert len(xs) > 3, f"no car drawn in frame {index}"
        reds.append((xs.mean(), ys.mean()))
    # The car moves across the picture as the simtrace says (image x ~ world x, image y ~ -world y).
    xs_world = [rows.X.iloc[i] for i in (10, len(rows) // 3, len(rows) - 5)]
    ys_world = [rows.Y.iloc[i] for i in (10, len(rows) // 3, len(rows) - 5)]
    assert np.corrcoef([x for x, _ in reds], xs_world)[0, 1] > 0.9
    assert np.corrcoef([y for _, y in reds], ys_world)[0, 1] < -0.9


def test_mcap_has_the_foxglove_channels_and_one_message_per_step(recorded):
    root, _, report = recorded
    rows = simtrace_of(root, report)
    steps = len(rows)
    expected = {
        "/camera/FRONT_FACING_CAMERA": ("foxglove.RawImage", "protobuf", steps),
        "/camera/rgb": ("foxglove.CompressedImage", "protobuf", steps),
        "/car/pose": ("foxglove.PoseInFrame", "protobuf", steps),
        "/car/action": ("racer.Action", "jsonschema", steps),
        "/car/reward": ("racer.Reward", "jsonschema", steps),
        "/car/status": ("racer.Status", "jsonschema", steps),
        "/simtrace": ("racer.SimtraceRow", "jsonschema", steps),
        "/track": ("foxglove.SceneUpdate", "protobuf", 1),
    }
    with (root / report.keys["mcap"]).open("rb") as handle:
        reader = make_reader(handle, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()
        channels = {channel.topic: channel for channel in summary.channels.values()}
        assert set(channels) == set(expected)
        for topic, (schema_name, encoding, count) in expected.items():
            schema = summary.schemas[channels[topic].schema_id]
            assert (schema.name, schema.encoding) == (schema_name, encoding), topic
            assert summary.statistics.channel_message_counts[channels[topic].id] == count, topic
        handle.seek(0)
        poses, statuses, images = [], [], []
        for _schema, _channel, message in make_reader(handle).iter_messages(topics=["/car/status"]):
            statuses.append(json.loads(message.data)["episode_status"])
        handle.seek(0)
        reader = make_reader(handle, decoder_factories=[DecoderFactory()])
        for _, channel, message, decoded in reader.iter_decoded_messages(
            topics=["/car/pose", "/camera/FRONT_FACING_CAMERA"]
        ):
            (poses if channel.topic == "/car/pose" else images).append((message.log_time, decoded))
    assert statuses == list(rows.episode_status)
    assert [time for time, _ in poses] == [round(t * 1e9) for t in rows.tstamp]
    # The pose is the car origin; the simtrace's X, Y is the front of the car, 0.14 m ahead along the heading.
    for (_, pose), (_, row) in zip(poses[::20], rows.iloc[::20].iterrows(), strict=True):
        position = pose.pose.position
        assert np.hypot(row.X - position.x, row.Y - position.y) == pytest.approx(0.14, abs=1e-4)
        assert pose.frame_id == "track"
    _, image = images[5]
    assert (image.width, image.height, image.encoding, len(image.data)) == (160, 120, "mono8", 160 * 120)


def test_summary_reports_laps_timings_and_files(recorded):
    root, _, report = recorded
    summary = json.loads((root / report.keys["summary"]).read_bytes())
    assert summary["mode"] == "deepracer" and summary["track"] == "racer_oval"
    assert summary["rules"]["number_of_resets"] == 2
    assert [lap["status"] for lap in summary["laps"]] == ["lap_complete"]
    assert summary["laps"][0]["put_backs"] == 1 and summary["laps"][0]["off_track_count"] == 1
    assert summary["timings"]["steps"] == len(simtrace_of(root, report))
    assert summary["timings"]["video_frames"] == report.video_frames
    assert summary["files"] == report.keys
    assert "Lap complete" in report.table and "resets" in report.table.splitlines()[0]


def test_evaluation_params_use_deepracers_yaml_keys(recorded):
    root, _, report = recorded
    params = parse_training_params((root / report.keys["params"]).read_text(), source="evaluation_params.yaml")
    assert params.values["JOB_TYPE"] == "EVALUATION" and params.values["WORLD_NAME"] == "racer_oval"
    assert (
        params.values["NUMBER_OF_TRIALS"],
        params.values["NUMBER_OF_RESETS"],
        params.values["OFF_TRACK_PENALTY"],
    ) == ("1", "2", "0.4")
    assert (
        params.values["IS_CONTINUOUS"] == "false" and params.values["METRICS_S3_OBJECT_KEY"] == report.keys["metrics"]
    )


def test_a_second_evaluation_in_the_same_second_takes_the_next_free_second(tmp_path):
    """Still 14 digits, the only evaluation folder name deepracer-utils reads."""
    first, _ = run_scripted(tmp_path, exits={0: [5.0]}, now=NOW)
    second, _ = run_scripted(tmp_path, exits={0: [5.0]}, now=NOW)
    assert first.layout.run_name == "evaluation-20261122073005"
    assert second.layout.run_name == "evaluation-20261122073006"
    assert first.keys["simtrace"] != second.keys["simtrace"]
    assert second.keys["metrics"] == "scripted-model/metrics/evaluation/evaluation-20261122073006.json"


def test_lidar_models_record_a_laser_scan_per_step(tmp_path):
    from racer.shared.deepracer.model_metadata import model_metadata_to_dict, parse_model_metadata
    from tests.evaluation.scripted import CONTINUOUS_METADATA

    lidar_metadata = parse_model_metadata(
        {**model_metadata_to_dict(CONTINUOUS_METADATA), "sensor": ["FRONT_FACING_CAMERA", "LIDAR"]}, source="test"
    )
    report, _ = run_scripted(
        tmp_path,
        exits={0: [8.0]},
        deepracer=DeepRacerRules(number_of_trials=1, number_of_resets=0),
        mcap=True,
        model_metadata=lidar_metadata,
    )
    steps = len(simtrace_of(tmp_path, report))
    assert report.mcap_messages["/lidar/LIDAR"] == steps == report.mcap_messages["/car/pose"]
    with (tmp_path / report.keys["mcap"]).open("rb") as handle:
        scans = [
            decoded
            for _, _, _, decoded in make_reader(handle, decoder_factories=[DecoderFactory()]).iter_decoded_messages(
                topics=["/lidar/LIDAR"]
            )
        ]
    assert len(scans[0].ranges) == 64 and all(0.15 <= r <= 1.0 for r in scans[0].ranges)


def test_stereo_models_record_one_image_channel_per_eye_and_an_in_car_video(tmp_path):
    from racer.shared.deepracer.model_metadata import model_metadata_to_dict, parse_model_metadata
    from tests.evaluation.scripted import CONTINUOUS_METADATA

    stereo = parse_model_metadata(
        {**model_metadata_to_dict(CONTINUOUS_METADATA), "sensor": ["STEREO_CAMERAS"]}, source="test"
    )
    report, _ = run_scripted(
        tmp_path,
        exits={0: [6.0]},
        deepracer=DeepRacerRules(number_of_trials=1, number_of_resets=0),
        mcap=True,
        video=VideoOptions(width_px=160, height_px=120),
        model_metadata=stereo,
    )
    steps = len(simtrace_of(tmp_path, report))
    assert report.mcap_messages["/camera/STEREO_CAMERAS/0"] == report.mcap_messages["/camera/STEREO_CAMERAS/1"] == steps
    assert "/camera/STEREO_CAMERAS" not in report.mcap_messages
    assert report.video_frames["camera-incar"] == steps
