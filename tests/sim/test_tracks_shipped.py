"""The project's own tracks: DeepRacer format, valid roads, reproducible from the generator; the track CLI."""

from __future__ import annotations

import numpy as np
import pytest
from click.testing import CliRunner
from shapely.geometry import LinearRing, Polygon

from racer.shared.sim.config import DEFAULT_TRACK
from racer.shared.sim.tracks.track import Track, available_tracks, default_tracks_dir
from racer.track.cli import track_group
from tools.track_design import DESIGNS, write_tracks


def test_at_least_three_original_tracks_in_deepracer_format():
    names = available_tracks()
    assert len(names) >= 3 and DEFAULT_TRACK in names
    lengths = []
    for name in names:
        raw = np.load(default_tracks_dir() / f"{name}.npy", allow_pickle=False)
        assert raw.dtype == np.float64 and raw.ndim == 2 and raw.shape[1] == 6
        assert np.array_equal(raw[0], raw[-1]), name
        widths = np.hypot(*(raw[:, 2:4] - raw[:, 4:6]).T)
        assert widths.min() >= 0.76 - 1e-9 and widths.max() <= 1.07 + 1e-9, name
        assert Polygon(raw[:, 4:6], [raw[:, 2:4]]).is_valid
        assert LinearRing(raw[:, 0:2]).is_ccw
        spacing = np.linalg.norm(np.diff(raw[:, 0:2], axis=0), axis=1)
        assert spacing.min() > 0.05 and spacing.max() < 0.3
        lengths.append(Track.load(name).length_m)
    assert 10.0 <= Track.load(DEFAULT_TRACK).length_m <= 15.0
    assert max(lengths) > 1.5 * min(lengths)


def test_generator_reproduces_the_committed_files(tmp_path):
    written = write_tracks(tmp_path)
    assert {p.stem for p in written} == {d.name for d in DESIGNS}
    for path in written:
        np.testing.assert_array_equal(np.load(path), np.load(default_tracks_dir() / path.name))


def test_no_deepracer_route_was_copied(deepracer_data):
    ours = [np.load(default_tracks_dir() / f"{name}.npy") for name in available_tracks()]
    for route in (deepracer_data / "routes").glob("*.npy"):
        theirs = np.load(route)
        assert all(mine.shape != theirs.shape or not np.allclose(mine, theirs) for mine in ours)


def test_track_cli_list_show_plot(tmp_path, deepracer_data):
    runner = CliRunner()
    listed = runner.invoke(track_group, ["list"])
    assert listed.exit_code == 0 and DEFAULT_TRACK in listed.output
    shown = runner.invoke(track_group, ["show", str(deepracer_data / "routes" / "reinvent_base.npy")])
    assert shown.exit_code == 0
    assert "length_m: 17.7092" in shown.output and "waypoints: 119" in shown.output and "width_m:" in shown.output
    out = tmp_path / "plot.png"
    plotted = runner.invoke(track_group, ["plot", DEFAULT_TRACK, str(out)])
    assert plotted.exit_code == 0 and out.stat().st_size > 5000
    missing = runner.invoke(track_group, ["show", "no_such_track"])
    assert missing.exit_code != 0 and "no_such_track" in missing.output


@pytest.mark.parametrize("name", [d.name for d in DESIGNS])
def test_every_track_drives_in_the_env(name, make_env):
    env = make_env(track=name)
    env.reset(seed=0)
    for _ in range(5):
        _, _, terminated, _, info = env.step(2)
    assert not terminated and info["params"]["all_wheels_on_track"]
    assert info["params"]["track_length"] == pytest.approx(Track.load(name).length_m)
