"""Every SimApp track by name on a fresh install: the shipped catalogue, fetching on first use, the cache, the errors.

The route files are the SimApp's own, read from ../shared/deepracer-data/simapp-routes (all 127, commit 01f5f015 of
aws-deepracer-community/deepracer-simapp) through RACER_TRACKS_URL, as a folder, as file:// and once over a real HTTP
server on loopback; no test reaches the SimApp's repository itself.
"""

from __future__ import annotations

import functools
import http.server
import shutil
import subprocess
import sys
import threading

import pytest
from click.testing import CliRunner

from racer.shared.config import route_cache, tracks_url
from racer.shared.sim.tracks.catalog import resolve_track
from racer.shared.sim.tracks.route_fetch import (
    RouteFetchError,
    RouteSource,
    default_tracks_url,
    fetch_route,
    is_cached,
    route_address,
)
from racer.shared.sim.tracks.route_search import RouteNotFoundError, find_route
from racer.shared.sim.tracks.simapp_routes import shipped_catalogue, shipped_catalogue_path
from racer.shared.sim.tracks.track import Track
from racer.track.cli import track_group
from tests.shared_data import REPO_ROOT, SHARED_DATA

SIMAPP_COMMIT = "01f5f015fd852f952b351643898d4beb4f36494b"  # SOURCES.md: simapp-routes/
DROA_COMMIT = "61af778f9b1d904a6318b746fc3e5a8ddac525ce"  # SOURCES.md: droa/tracks.json

pytestmark = pytest.mark.usefixtures("deepracer_data")


@pytest.fixture
def fresh_install(tmp_path, monkeypatch):
    """No route library, no RACER_ROUTES_PATH, an empty cache, and the SimApp's route files served from a folder."""
    monkeypatch.delenv("RACER_ROUTES_PATH", raising=False)
    monkeypatch.setenv("RACER_DATA_HOME", str(tmp_path / "data"))
    monkeypatch.setenv("RACER_CACHE_HOME", str(tmp_path / "cache"))
    monkeypatch.setenv("RACER_TRACKS_URL", (SHARED_DATA / "simapp-routes").as_uri())
    return tmp_path / "cache" / "routes"


def test_the_default_address_is_the_simapps_repository_at_the_pinned_commit():
    catalogue = shipped_catalogue()
    assert catalogue.simapp_commit == SIMAPP_COMMIT
    assert tracks_url({}) is None  # unset: racer uses the default below
    url = default_tracks_url(catalogue.simapp_commit)
    assert (
        url
        == f"https://raw.githubusercontent.com/aws-deepracer-community/deepracer-simapp/{SIMAPP_COMMIT}/bundle/routes/"
    )
    assert route_address(url, "penbay_pro.npy") == url + "penbay_pro.npy"


def test_the_cache_follows_the_users_folders(tmp_path):
    assert route_cache({"RACER_CACHE_HOME": str(tmp_path / "c")}) == (tmp_path / "c" / "routes").resolve()
    assert route_cache({"XDG_CACHE_HOME": str(tmp_path / "x")}) == (tmp_path / "x" / "racer" / "routes").resolve()
    assert route_cache({"HOME": str(tmp_path / "h")}) == (tmp_path / "h" / ".cache" / "racer" / "routes").resolve()


def test_the_catalogue_names_every_simapp_route_and_the_generator_reproduces_it(tmp_path):
    names = (SHARED_DATA / "simapp-routes" / "tracks.txt").read_text().split()
    catalogue = shipped_catalogue()
    assert sorted(route.name for route in catalogue.routes) == sorted(names)
    assert len(catalogue.routes) == 127
    out = tmp_path / "catalogue.json"
    subprocess.run(
        [
            sys.executable,
            str(REPO_ROOT / "tools" / "simapp_route_catalogue.py"),
            str(SHARED_DATA / "simapp-routes"),
            str(SHARED_DATA / "droa" / "tracks.json"),
            "--simapp-commit",
            SIMAPP_COMMIT,
            "--droa-commit",
            DROA_COMMIT,
            "--out",
            str(out),
        ],
        check=True,
        capture_output=True,
    )
    assert out.read_bytes() == shipped_catalogue_path().read_bytes()


def test_every_catalogue_entry_fetches_and_matches_its_hash(tmp_path):
    source = RouteSource((SHARED_DATA / "simapp-routes").as_uri(), tmp_path / "cache")
    for route in shipped_catalogue().routes:
        path = fetch_route(route, source)
        assert path.parent == tmp_path / "cache" and is_cached(route, source.cache_dir), route.name
        track = Track.load(path)
        assert abs(track.length_m - route.length_m) < 0.01, route.name


def test_a_simapp_checkout_and_an_http_mirror_serve_as_well(tmp_path):
    route = shipped_catalogue().route("penbay_pro")
    checkout = tmp_path / "deepracer-simapp"
    (checkout / "bundle" / "routes").mkdir(parents=True)
    shutil.copyfile(SHARED_DATA / "simapp-routes" / "penbay_pro.npy", checkout / "bundle" / "routes" / "penbay_pro.npy")
    assert fetch_route(route, RouteSource(str(checkout), tmp_path / "a")).is_file()

    handler = functools.partial(http.server.SimpleHTTPRequestHandler, directory=str(SHARED_DATA / "simapp-routes"))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        url = f"http://127.0.0.1:{server.server_address[1]}/"
        path = fetch_route(route, RouteSource(url, tmp_path / "b"))
        assert path.read_bytes() == (SHARED_DATA / "simapp-routes" / "penbay_pro.npy").read_bytes()
    finally:
        server.shutdown()
        server.server_close()


def test_a_file_with_another_hash_is_refused_and_not_cached(tmp_path):
    mirror = tmp_path / "mirror"
    mirror.mkdir()
    shutil.copyfile(SHARED_DATA / "simapp-routes" / "Oval_track.npy", mirror / "reinvent_base.npy")
    route = shipped_catalogue().route("reinvent_base")
    with pytest.raises(RouteFetchError, match="not the SimApp's reinvent_base.npy"):
        fetch_route(route, RouteSource(str(mirror), tmp_path / "cache"))
    assert not (tmp_path / "cache" / "reinvent_base.npy").exists()


def test_no_network_names_the_track_the_address_and_both_ways_out(tmp_path, fresh_install, monkeypatch):
    monkeypatch.setenv("RACER_TRACKS_URL", "http://127.0.0.1:9/routes/")  # the discard port: nothing listens
    with pytest.raises(RouteNotFoundError) as caught:
        find_route("2022_reinvent_champ_ccw")
    message = str(caught.value)
    assert "2022_reinvent_champ_ccw" in message and "http://127.0.0.1:9/routes/2022_reinvent_champ_ccw.npy" in message
    assert "racer track fetch" in message and "racer track import" in message


def test_first_use_fetches_later_uses_need_no_network(fresh_install, monkeypatch):
    assert find_route("reinvent_base") == fresh_install / "reinvent_base.npy"
    monkeypatch.setenv("RACER_TRACKS_URL", "http://127.0.0.1:9/")
    assert Track.load("reinvent_base").num_waypoints > 50  # from the cache


def test_deepracer_on_aws_names_resolve_with_no_import(fresh_install):
    resolved = resolve_track("Forever Raceway", "clockwise")
    assert resolved.world_name == "2024_reinvent_champ_cw"
    assert resolved.droa is not None and resolved.droa.difficulty is not None and resolved.droa.description
    assert Track.load(resolved.world_name).is_ccw is False
    assert resolve_track("2022_reinvent_champ", "counter-clockwise").world_name == "2022_reinvent_champ_ccw"


def test_racer_track_list_fetch_show_on_a_fresh_install(fresh_install, tmp_path):
    runner = CliRunner()
    listed = runner.invoke(track_group, ["list"])
    assert listed.exit_code == 0, listed.output
    names = {line.split("\t")[0] for line in listed.output.splitlines()}
    assert {route.name for route in shipped_catalogue().routes} <= names and "racer_oval" in names
    found = runner.invoke(track_group, ["list", "--search", "forever"])
    assert found.exit_code == 0, found.output
    assert {line.split("\t")[0] for line in found.output.splitlines()} == {
        "2024_reinvent_champ_ccw",
        "2024_reinvent_champ_cw",
    }
    assert "Forever Raceway" in found.output and "not fetched" in found.output

    shown = runner.invoke(track_group, ["show", "Forever Raceway", "--direction", "clockwise"])
    assert shown.exit_code == 0, shown.output
    assert "track: 2024_reinvent_champ_cw" in shown.output and "file: the SimApp's file" in shown.output
    assert f"cache: {fresh_install}" in shown.output and "difficulty:" in shown.output

    fetched = runner.invoke(track_group, ["fetch", "penbay_pro", "Spain_track"])
    assert fetched.exit_code == 0, fetched.output
    assert is_cached(shipped_catalogue().route("Spain_track"), fresh_install)
    (fresh_install / "penbay_pro.npy").write_bytes(b"broken")
    verified = runner.invoke(track_group, ["fetch", "--verify"])
    assert verified.exit_code == 1 and "penbay_pro" in verified.output, verified.output
    unknown = runner.invoke(track_group, ["fetch", "no_such_track"])
    assert unknown.exit_code != 0 and "no_such_track" in unknown.output


def test_an_imported_route_under_a_catalogue_name_is_used_and_said_to_differ(fresh_install, tmp_path):
    own = tmp_path / "own"
    own.mkdir()
    shutil.copyfile(SHARED_DATA / "simapp-routes" / "Oval_track.npy", own / "reinvent_base.npy")
    runner = CliRunner()
    assert runner.invoke(track_group, ["import", str(own / "reinvent_base.npy")]).exit_code == 0
    assert find_route("reinvent_base").parent == tmp_path / "data" / "routes"
    shown = runner.invoke(track_group, ["show", "reinvent_base"])
    assert shown.exit_code == 0, shown.output
    assert "not the SimApp's file" in shown.output
