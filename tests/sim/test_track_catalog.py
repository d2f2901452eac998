"""Track names and directions: route names, DeepRacer-on-AWS display names and trackIds, `racer track list/import`.

The real route files are read in place from ../shared/deepracer-data/routes (9 of the SimApp's 127); every SimApp
route comes by name from ../shared/deepracer-data/simapp-routes (the suite's RACER_TRACKS_URL, tests/conftest.py).
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import click
import pytest
from click.testing import CliRunner

from racer.options.track import resolved_track_name
from racer.shared.sim.tracks.catalog import resolve_track, world_name_for_direction
from racer.shared.sim.tracks.droa_tracks import CATALOGUE_FILE, TrackDirectionError, parse_catalogue, read_catalogue
from racer.shared.sim.tracks.route_search import default_tracks_dir, search_folders
from racer.shared.sim.tracks.track import Track, available_tracks
from racer.track.cli import track_group
from tests.shared_data import SHARED_DATA

# Made-up display names over the shared routes (racer ships no DeepRacer-on-AWS list): one two-direction track,
# one single-direction track, one disabled.
CATALOGUE = {
    "tracks": [
        {
            "name": "Test Smile Way",
            "trackId": "reInvent2019_track",
            "defaultDirection": "COUNTER_CLOCKWISE",
            "enabledDirections": ["CLOCKWISE", "COUNTER_CLOCKWISE"],
            "length": 23.12,
            "disabled": False,
        },
        {
            "name": "Test Bow Loop",
            "trackId": "Bowtie_track",
            "defaultDirection": "COUNTER_CLOCKWISE",
            "enabledDirections": ["COUNTER_CLOCKWISE"],
            "length": 17.43,
        },
        {"name": "Gone", "trackId": "Oval_track", "enabledDirections": ["CLOCKWISE"], "disabled": True},
    ]
}


@pytest.fixture
def routes(deepracer_data, tmp_path, monkeypatch):
    """The shared routes on RACER_ROUTES_PATH, an empty route library, and the test catalogue in a folder after."""
    extra = tmp_path / "extra"
    extra.mkdir()
    (extra / CATALOGUE_FILE).write_text(json.dumps(CATALOGUE))
    monkeypatch.setenv("RACER_ROUTES_PATH", f"{deepracer_data / 'routes'}{os.pathsep}{extra}")
    monkeypatch.setenv("RACER_DATA_HOME", str(tmp_path / "home"))
    monkeypatch.setenv("RACER_CACHE_HOME", str(tmp_path / "cache"))
    return deepracer_data / "routes"


def test_the_route_library_comes_after_racer_routes_path_and_before_tracks(tmp_path):
    env = {"RACER_ROUTES_PATH": str(tmp_path / "a"), "HOME": str(tmp_path / "h")}
    library = (tmp_path / "h" / ".local" / "share" / "racer" / "routes").resolve()
    assert search_folders(env) == ((tmp_path / "a").resolve(), library, default_tracks_dir())
    assert search_folders({"RACER_DATA_HOME": str(tmp_path / "d")})[0] == (tmp_path / "d" / "routes").resolve()
    assert search_folders({"XDG_DATA_HOME": str(tmp_path / "x")})[0] == (tmp_path / "x" / "racer" / "routes").resolve()


def test_both_catalogue_formats_parse_and_disabled_tracks_are_left_out(tmp_path):
    tracks = parse_catalogue(CATALOGUE)
    assert [t.track_id for t in tracks] == ["reInvent2019_track", "Bowtie_track"]
    compact = tmp_path / "c.json"
    compact.write_text(json.dumps([t.to_compact() for t in tracks]))
    assert read_catalogue(compact) == tracks
    with pytest.raises(ValueError, match="name and trackId"):
        parse_catalogue([{"name": "x"}])


def test_display_names_and_directions_resolve_to_the_simapps_route_names(routes):
    assert resolve_track("Test Smile Way", "clockwise").world_name == "reInvent2019_track_cw"
    assert resolve_track("test smile way", "CW").world_name == "reInvent2019_track_cw"
    # The SimApp's reInvent2019_track_ccw is in racer's catalogue (fetched when loaded); among folders without it,
    # the bare route runs counter-clockwise, so it is the one.
    assert resolve_track("Test Smile Way", "counter-clockwise").world_name == "reInvent2019_track_ccw"
    assert resolve_track("Test Smile Way", "counter-clockwise", search_folders()).world_name == "reInvent2019_track"
    assert resolve_track("Test Smile Way").direction == "COUNTER_CLOCKWISE"  # its default
    assert resolve_track("reInvent2019_track").world_name == "reInvent2019_track"  # a route name stays as given
    # A single-direction track is its bare trackId, as DeepRacer on AWS sends it; the other direction is refused.
    assert resolve_track("Test Bow Loop", "ccw").world_name == "Bowtie_track"
    with pytest.raises(TrackDirectionError, match="offers counter-clockwise"):
        resolve_track("Test Bow Loop", "clockwise")
    with pytest.raises(ValueError, match="expected clockwise"):
        resolve_track("Test Bow Loop", "sideways")
    with pytest.raises(TrackDirectionError, match="is the clockwise direction"):
        resolve_track("reInvent2019_track_cw", "counter-clockwise")


def test_world_name_for_direction_keeps_single_direction_tracks_bare(routes):
    assert world_name_for_direction("Bowtie_track", False) == "Bowtie_track"
    assert world_name_for_direction("reInvent2019_track", True) == "reInvent2019_track_cw"
    assert world_name_for_direction("reInvent2019_track", None) == "reInvent2019_track"
    with pytest.raises(TrackDirectionError, match="offers counter-clockwise"):
        world_name_for_direction("Bowtie_track", True)


def test_without_a_catalogue_the_route_files_tell_the_directions(deepracer_data, monkeypatch, tmp_path):
    """Folders given explicitly (as `--tracks-dir` does) leave racer's catalogue out: the files alone decide."""
    folders = [deepracer_data / "routes"]
    assert world_name_for_direction("Vegas_track", False, folders) == "Vegas_track"
    with pytest.raises(TrackDirectionError, match="Vegas_track.npy runs counter-clockwise"):
        world_name_for_direction("Vegas_track", True, folders)
    assert world_name_for_direction("Nowhere", True, folders) == "Nowhere_cw"  # as the SimApp: loading it says where
    monkeypatch.setenv("RACER_DATA_HOME", str(tmp_path))
    with pytest.raises(click.BadParameter, match="offers counter-clockwise"):
        resolved_track_name("Vegas_track", "clockwise")


def test_every_available_route_loads(routes):
    names = available_tracks()
    assert {"reInvent2019_track", "Bowtie_track", "racer_oval"} <= set(names)
    for name in names:
        track = Track.load(name)
        assert track.length_m > 1.0 and track.num_waypoints >= 4, name


def test_every_deepracer_on_aws_name_and_enabled_direction_resolves(tmp_path, monkeypatch):
    """DeepRacer on AWS's own list (shipped in racer's route catalogue) against the SimApp's route files, fetched from
    the shared folder on first use."""
    monkeypatch.delenv("RACER_ROUTES_PATH", raising=False)
    monkeypatch.setenv("RACER_DATA_HOME", str(tmp_path / "home"))
    catalogue = read_catalogue(SHARED_DATA / "droa" / "tracks.json")
    assert len(catalogue) >= 60
    for entry in catalogue:
        for direction in entry.directions:
            world = resolve_track(entry.name, direction).world_name
            track = Track.load(world)
            assert track.is_ccw == (direction == "COUNTER_CLOCKWISE"), (entry.name, direction, world)
            if len(entry.directions) == 1:
                assert world == entry.track_id


def test_racer_track_import_list_and_show(routes, tmp_path):
    runner = CliRunner()
    imported = runner.invoke(
        track_group, ["import", str(routes / "Oval_track.npy"), "--droa", str(_write(tmp_path, CATALOGUE))]
    )
    assert imported.exit_code == 0, imported.output
    library = tmp_path / "home" / "routes"
    assert (library / "Oval_track.npy").is_file() and (library / CATALOGUE_FILE).is_file()
    listed = runner.invoke(track_group, ["list", "--search", "smile"])
    assert listed.exit_code == 0, listed.output
    rows = [line.split("\t") for line in listed.output.splitlines()]
    assert rows[0] == [
        "reInvent2019_track",
        "Test Smile Way",
        "23.12 m",
        "1.07 m wide",
        "cw,ccw",
        str(routes.resolve()),
    ]
    assert rows[1][0] == "reInvent2019_track_ccw" and rows[1][-2:] == ["ccw", "not fetched"]  # the SimApp's, by name
    assert rows[2][0] == "reInvent2019_track_cw" and rows[2][-2:] == ["cw", str(routes.resolve())]
    droa = runner.invoke(track_group, ["list", "--droa", "--search", "test"])
    assert droa.exit_code == 0, droa.output
    assert [line.split("\t")[1] for line in droa.output.splitlines()] == ["Test Bow Loop", "Test Smile Way"]
    shown = runner.invoke(track_group, ["show", "Test Smile Way", "--direction", "clockwise"])
    assert shown.exit_code == 0 and "track: reInvent2019_track_cw" in shown.output, shown.output
    refused = runner.invoke(track_group, ["show", "Test Bow Loop", "--direction", "clockwise"])
    assert refused.exit_code == 1 and "offers counter-clockwise" in refused.output


def _write(folder: Path, data: object) -> Path:
    path = folder / "tracks.json"
    path.write_text(json.dumps(data))
    return path


def _route_paths() -> list[Path]:
    """racer's own routes and every SimApp route, fetched by name into the test session's cache."""
    from racer.shared.sim.tracks.route_fetch import fetch_catalogue_route
    from racer.shared.sim.tracks.simapp_routes import shipped_catalogue

    return sorted(default_tracks_dir().glob("*.npy")) + [
        fetch_catalogue_route(route.name) for route in shipped_catalogue().routes
    ]


def _drive(path: Path) -> None:
    from racer.shared.sim.config import EnvConfig
    from racer.shared.sim.env import DeepRacerEnv

    env = DeepRacerEnv(EnvConfig(track=path))
    try:
        observation, _ = env.reset(seed=0)
        assert observation[next(iter(observation))].any(), path  # the camera saw something
        for _ in range(3):
            _, reward, _, _, info = env.step(4)  # straight ahead
            assert reward == reward, path  # a number, not NaN
    finally:
        env.close()


@pytest.mark.usefixtures("deepracer_data")
@pytest.mark.slow
def test_every_route_renders_and_steps():
    """Each route racer ships and each of the SimApp's 127 builds a world, renders and steps."""
    paths = _route_paths()
    assert len(paths) >= 127 + 3
    for path in paths:
        _drive(path)
