"""Each track's look (`track_looks.py`): the table's facts, which look a scene gets, and what the camera sees."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from racer.shared.sim.config import EnvConfig
from racer.shared.sim.env import DeepRacerEnv
from racer.shared.sim.scene import world_look
from racer.shared.sim.scene.track_looks import ROLES, TRACK_LOOKS, look_for, track_look, world_look_of
from racer.shared.sim.sensors.camera import rgb_to_y

GOLDEN_FRAMES = Path(__file__).parent / "data" / "reinvent_base_frames_before_track_looks.npz"
"""re:Invent 2018 base, front camera at 0, 1/3 and 2/3 of the lap on the centre line, rendered (egl) by the commit
before track looks existed: the closed-loop yardstick's frames must not change."""


def test_table_entries_are_colours_that_trace_to_simapp_files():
    assert len(TRACK_LOOKS) >= 120
    for name, entry in TRACK_LOOKS.items():
        assert entry.world == name
        assert entry.tag in ("v5.3.3", "v6.0.5")
        assert entry.world_file == f"bundle/worlds/{name}.world"
        sources = dict(entry.sources)
        for role in ROLES:
            colour = getattr(entry, role)
            if colour is None:
                assert role in ("wall", "backdrop") and role not in sources
                continue
            assert len(colour) == 3 and all(0.0 <= c <= 1.0 for c in colour), (name, role, colour)
            # Every colour names the mesh file and effect it came from (and the texture when it is a mean).
            assert re.fullmatch(
                r"bundle/meshes/\S+\.dae effect \S+ (texture .+ \(mean\)|diffuse colour)", sources[role]
            )
        if entry.geometry:
            assert entry.geometry_source.startswith("bundle/meshes/")
            assert all(0.0 < v < 20.0 for _, v in entry.geometry)


def test_table_holds_what_the_files_say():
    """Spot checks against the SimApp files (v5.3.3): trackgen's shared textures, caecer's own field."""
    april = TRACK_LOOKS["2022_april_open_cw"]
    assert np.allclose(np.array(april.road) * 255, (64, 63, 61), atol=0.6)
    assert np.allclose(np.array(april.field) * 255, (126, 133, 65), atol=0.6)
    assert np.allclose(np.array(april.wall) * 255, (36, 70, 81), atol=0.6)
    assert dict(april.geometry)["edge_line_width_m"] == pytest.approx(0.0762)
    assert dict(april.geometry)["dash_length_m"] == pytest.approx(0.0508)
    assert "textures/road.png" in dict(april.sources)["road"]
    assert np.allclose(np.array(TRACK_LOOKS["caecer_gp"].field) * 255, (73, 93, 29), atol=0.6)
    assert TRACK_LOOKS["Singapore_f1"].tag == "v6.0.5"


def test_which_look_a_scene_gets():
    for name in ("reinvent_base", "racer_oval", "racer_bean", "no_such_track"):
        assert track_look(name) is None
        for world in world_look.LOOKS:
            assert look_for(name, world) is world_look.LOOKS[world]
    assert track_look("reInvent2019_track_cw").world == "reInvent2019_track_cw"
    assert track_look("Bowtie_track_cw").world == "Bowtie_track"  # a direction suffix the SimApp has no world for
    own = look_for("reInvent2019_track", "base")
    assert own is world_look_of("reInvent2019_track") and own.name == "track:reInvent2019_track"
    assert look_for("reInvent2019_track", "carpet") is world_look.LOOKS["carpet"]


def _frames(route: Path, world: str, ndists: tuple[float, ...]) -> np.ndarray:
    env = DeepRacerEnv(EnvConfig(track=route, world=world))
    try:
        env.reset(seed=0)
        frames = []
        for ndist in ndists:
            x, y, yaw = env.track.pose_at(ndist, "center")
            env.teleport(x, y, yaw)
            env._camera.start(env.data, "front_camera")
            frames.append(env._camera.finish().copy())
        return np.stack(frames)
    finally:
        env.close()


def test_reinvent_2018_base_renders_as_before(deepracer_data):
    golden = np.load(GOLDEN_FRAMES)["frames"]
    frames = _frames(deepracer_data / "routes" / "reinvent_base.npy", "base", (0.0, 2 / 6, 4 / 6))
    assert frames.shape == golden.shape
    grey = [np.stack([rgb_to_y(f).astype(int) for f in fs]) for fs in (frames, golden)]
    difference = np.abs(grey[0] - grey[1])
    assert difference.mean() <= 1.0, difference.mean()


def test_a_track_with_its_own_look_renders_in_its_colours(deepracer_data):
    """reInvent2019_track: grey asphalt and olive grass (the SimApp's textures), not re:Invent 2018's navy and mint."""
    look = world_look_of("reInvent2019_track")
    frame = _frames(deepracer_data / "routes" / "reInvent2019_track.npy", "base", (0.0,))[0]
    road = np.median(frame[100:120, 20:50].reshape(-1, 3), axis=0)
    assert np.all(np.abs(road - look.road_rgb) <= 10), (road, look.road_rgb)
    r, g, b = (frame[..., i].astype(int) for i in range(3))
    field = (g > b + 30) & (r > b + 20)  # olive grass: green and red well above blue
    assert field.sum() >= 30
    assert np.all(np.abs(np.median(frame[field], axis=0) - look.field_rgb) <= 15)
    base_road = world_look.LOOKS["base"].road_rgb
    assert np.abs(road - base_road).max() > 20


def test_rendered_plot_works_for_every_track_racer_finds(tmp_path, deepracer_data, monkeypatch):
    """`racer track plot NAME OUT.png --rendered base` for the shared routes (on RACER_ROUTES_PATH) and tracks/."""
    from click.testing import CliRunner
    from PIL import Image

    from racer.shared.sim.tracks.route_search import available_routes, search_folders
    from racer.track.cli import track_group

    monkeypatch.setenv("RACER_ROUTES_PATH", str(deepracer_data / "routes"))
    names = available_routes(search_folders())
    assert {"reinvent_base", "reInvent2019_track", "Vegas_track", "racer_oval"} <= set(names)
    runner = CliRunner()
    for name in names:
        out = tmp_path / f"{name}.png"
        result = runner.invoke(track_group, ["plot", name, str(out), "--rendered", "base"])
        assert result.exit_code == 0, (name, result.output)
        pixels = np.asarray(Image.open(out).convert("RGB"))
        assert pixels.shape == (480, 640, 3)
        # The field is drawn in the track's own field colour (or re:Invent 2018's): a good share of the picture.
        look = world_look_of(name) or world_look.LOOKS["base"]
        near_field = np.abs(pixels.astype(int) - look.field_rgb).max(axis=2) <= 25
        assert near_field.mean() >= 0.2, (name, near_field.mean())
