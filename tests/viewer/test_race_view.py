"""`racer view RACE_FOLDER`: a finished race's leaderboard page over HTTP, its videos served with Range (so they
play and seek), and nothing else of the folder or outside it."""

from __future__ import annotations

import json

import imageio.v2 as imageio
import numpy as np
import pytest
from click.testing import CliRunner

from racer.viewer import cli as viewer_cli
from racer.viewer.race_app import NotARaceFolderError, create_race_app
from tests.viewer.conftest import ServedApp
from tests.viewer.test_viewer_http import get, raw_get


@pytest.fixture
def race_folder(tmp_path):
    """What `racer race` leaves: the board (html, json, csv), videos/, and the run's own files under entrants/."""
    folder = tmp_path / "races" / "cup"
    (folder / "videos").mkdir(parents=True)
    (folder / "entrants" / "alpha").mkdir(parents=True)
    video = folder / "videos" / "alpha-camera-incar.mp4"
    with imageio.get_writer(str(video), fps=15, codec="libx264", pixelformat="yuv420p", macro_block_size=2) as out:
        for index in range(15):
            out.append_data(np.full((64, 96, 3), index * 16, dtype=np.uint8))
    (folder / "leaderboard.html").write_text(
        '<!doctype html><h1>cup</h1><video src="videos/alpha-camera-incar.mp4"></video>'
    )
    (folder / "leaderboard.json").write_text(json.dumps({"leaderboard": [{"entrant": "alpha", "rank": 1}]}))
    (folder / "leaderboard.csv").write_text("rank,entrant\n1,alpha\n")
    (folder / "entrants" / "alpha" / "task.json").write_text('{"work_dir": "/home/me"}')
    (folder / "entrants" / "alpha" / "stderr.log").write_text("log")
    (tmp_path / "races" / "secret.json").write_text("{}")
    return folder


def test_the_board_and_its_videos_are_served_and_nothing_else(race_folder):
    with ServedApp(create_race_app(race_folder)) as served:
        status, kind, body = get(served.url + "/")
        assert status == 200 and kind.startswith("text/html") and b"<h1>cup</h1>" in body
        status, kind, body = get(served.url + "/videos/alpha-camera-incar.mp4")
        assert status == 200 and kind == "video/mp4" and body[4:8] == b"ftyp"
        size = len(body)
        status, _, part = get(served.url + "/videos/alpha-camera-incar.mp4", {"Range": "bytes=10-19"})
        assert status == 206 and part == body[10:20]  # seekable
        assert get(served.url + "/leaderboard.json")[0] == 200
        assert get(served.url + "/leaderboard.csv")[1].startswith("text/csv")
        assert size > 100
        for path in ("/entrants/alpha/task.json", "/entrants/alpha/stderr.log", "/videos/none.mp4"):
            assert get(served.url + path)[0] == 404, path
        assert raw_get(served.port, "/../secret.json") == 404
        assert raw_get(served.port, "/videos/../../secret.json") == 404


def test_racer_view_of_a_race_folder_serves_its_board(race_folder, monkeypatch):
    served = {}
    monkeypatch.setattr(viewer_cli, "serve", lambda app, host, port: served.update(app=app, port=port))
    result = CliRunner().invoke(viewer_cli.view_command, [str(race_folder), "--port", "8123"])
    assert result.exit_code == 0, result.output
    assert served["port"] == 8123 and f"race {race_folder}" in result.output
    with ServedApp(served["app"]) as app:
        assert b"<h1>cup</h1>" in get(app.url + "/")[2]
    live = CliRunner().invoke(viewer_cli.view_command, [str(race_folder), "--live"])
    assert live.exit_code != 0 and "finished race" in live.output


def test_a_folder_without_a_board_is_not_a_race(tmp_path):
    with pytest.raises(NotARaceFolderError, match="no finished race"):
        create_race_app(tmp_path)
