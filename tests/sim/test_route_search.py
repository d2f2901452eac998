"""Track names as DeepRacer users give them (WORLD_NAME): RACER_ROUTES_PATH's folders in order, racer's tracks/ last."""

from __future__ import annotations

import shutil

import numpy as np
import pytest
from click.testing import CliRunner

from racer.shared.config import route_folders
from racer.shared.sim.tracks.route_search import default_tracks_dir, search_folders
from racer.shared.sim.tracks.track import Track, TrackError
from racer.shared.worker_settings import WorkerSettings
from racer.track.cli import track_group


@pytest.fixture
def routes_path(deepracer_data, monkeypatch):
    folder = deepracer_data / "routes"
    monkeypatch.setenv("RACER_ROUTES_PATH", str(folder))
    return folder


def test_the_search_path_is_the_variables_folders_in_order_then_racers_tracks(tmp_path):
    first, second = tmp_path / "a", tmp_path / "b"
    environ = {"RACER_ROUTES_PATH": f"{first}:{second}:"}
    assert route_folders(environ) == (first, second)
    assert search_folders(environ) == (first, second, default_tracks_dir())
    assert search_folders({}) == (default_tracks_dir(),)


def test_a_deepracer_world_name_loads_from_the_routes_folder(routes_path):
    track = Track.load("reInvent2019_track")
    assert track.source == str(routes_path / "reInvent2019_track.npy")
    assert track.length_m == pytest.approx(23.118, abs=1e-3)  # docs/tracks.md
    assert Track.load("racer_oval").source == str(default_tracks_dir() / "racer_oval.npy")  # tracks/ still last


def test_an_earlier_folder_wins(tmp_path, deepracer_data, monkeypatch):
    mine = tmp_path / "mine"
    mine.mkdir()
    shutil.copy(deepracer_data / "routes" / "Oval_track.npy", mine / "reinvent_base.npy")
    monkeypatch.setenv("RACER_ROUTES_PATH", f"{mine}:{deepracer_data / 'routes'}")
    assert np.array_equal(
        Track.load("reinvent_base").waypoints, Track.load(deepracer_data / "routes" / "Oval_track.npy").waypoints
    )


def test_an_unknown_name_lists_where_it_looked(routes_path):
    with pytest.raises(TrackError) as info:
        Track.load("Nowhere_track")
    message = str(info.value)
    assert "Nowhere_track" in message and str(routes_path) in message and str(default_tracks_dir()) in message
    assert "RACER_ROUTES_PATH" in message


def test_track_direction_clockwise_appends_cw_or_ccw_as_deepracer_on_aws(routes_path, tmp_path, monkeypatch):
    """SimApp yaml_file.py: TRACK_DIRECTION_CLOCKWISE true -> WORLD_NAME + '_cw', false -> + '_ccw'."""
    monkeypatch.setenv("RACER_DATA_HOME", str(tmp_path))  # no route library of the user's
    params = {"WORLD_NAME": "reInvent2019_track", "TRACK_DIRECTION_CLOCKWISE": "true"}
    clockwise = WorkerSettings.from_training_params(params, source="training_params.yaml")
    assert clockwise.track == "reInvent2019_track_cw"
    track = Track.load(clockwise.track)
    assert not track.is_ccw and track.source.endswith("reInvent2019_track_cw.npy")
    counter = WorkerSettings.from_training_params({**params, "TRACK_DIRECTION_CLOCKWISE": "False"}, source="t.yaml")
    # The test folder has no reInvent2019_track_ccw; the SimApp has one, and racer fetches it by name.
    assert counter.track == "reInvent2019_track_ccw"
    assert Track.load(counter.track).is_ccw
    assert (
        WorkerSettings.from_training_params({"WORLD_NAME": "reInvent2019_track"}, source="t").track
        == "reInvent2019_track"
    )
    # The written training_params carry the resolved name, so a worker reading them back does not add it twice.
    again = WorkerSettings.from_training_params(clockwise.to_training_params("m", 1), source="t")
    assert again.track == "reInvent2019_track_cw"


def test_racer_track_commands_take_deepracer_names(routes_path):
    shown = CliRunner().invoke(track_group, ["show", "reinvent_base"])
    assert shown.exit_code == 0, shown.output
    assert "length_m: 17.7092" in shown.output
    listed = CliRunner().invoke(track_group, ["list"])
    assert listed.exit_code == 0, listed.output
    names = [line.split("\t")[0] for line in listed.output.splitlines()]
    assert {"reInvent2019_track", "Straight_track", "racer_oval"} <= set(names)
