"""DeepRacer's own world meshes and textures, read from a SimApp-layout folder (the shared copy of bundle/)."""

from __future__ import annotations

import shutil

import numpy as np
import pytest

from racer.shared.sim.scene.simapp_world import SimappWorldError, load_simapp_world


@pytest.fixture(scope="module")
def bundle(deepracer_data):
    return deepracer_data / "worlds" / "simapp" / "bundle"


def test_base_world_in_metres_with_the_world_files_lights(bundle):
    world = load_simapp_world(bundle, "base")
    assert world.ambient == (0.5, 0.5, 0.5)
    sun, point = world.lights
    assert sun.directional and sun.diffuse == (1.0, 1.0, 0.8) and sun.direction == (-0.5, 0.1, -0.9)
    assert not point.directional and point.position_m == (0.0, 0.0, 15.0) and point.attenuation == (0.4, 0.01, 0.0)
    extent = np.concatenate([part.vertices for part in world.parts])
    # reinvent_base.dae is in metres: the field spans -0.59..8.58 x -0.61..5.80 and the walls are 1 m high.
    np.testing.assert_allclose(extent.min(axis=0), [-0.587, -0.613, 0.0], atol=0.01)
    np.testing.assert_allclose(extent.max(axis=0), [8.575, 5.795, 1.0], atol=0.01)
    textures = {part.texture.name for part in world.parts}
    assert {"road.png", "outerLine.png", "centerLine.png", "field.png", "wall.png"} <= textures


def test_centimetre_meshes_are_scaled_by_their_node_matrix(bundle, deepracer_data):
    """carpet: centimetre meshes with a 0.01 node scale; the lines lie on the route, the walls are 2 m high."""
    world = load_simapp_world(bundle, "carpet")
    parts = {part.name.split("_")[0]: part for part in world.parts}
    walls = np.concatenate([p.vertices for p in world.parts if "wall" in p.name])
    assert walls[:, 2].max() == pytest.approx(2.0, abs=1e-6)
    route = np.load(deepracer_data / "routes" / "reinvent_base.npy")
    dashes = parts["innerLinesLink"].vertices[:, :2]
    distance = np.min(np.linalg.norm(dashes[:, None, :] - route[None, :, 0:2], axis=2), axis=1)
    assert np.median(distance) < 0.05  # the dashed line follows the centre line


def test_env_draws_deepracers_meshes(bundle, deepracer_data):
    from racer.shared.sim.config import EnvConfig
    from racer.shared.sim.env import DeepRacerEnv

    route = deepracer_data / "routes" / "reinvent_base.npy"
    env = DeepRacerEnv(EnvConfig(track=route, simapp_dir=bundle))
    try:
        env.reset(seed=0)
        assert env.model.ngeom > 6 and "simapp_0" in {env.model.geom(i).name for i in range(env.model.ngeom)}
        x, y, yaw = env.track.pose_at(0.0, "center")
        env.teleport(x, y, yaw)
        env._camera.start(env.data, "front_camera")
        frame = env._camera.finish()
        road = np.median(frame[100:120, 20:50].reshape(-1, 3), axis=0)
        # Road.png's mean colour is (36, 49, 64); under racer's light a floor shows about 1.0x its texture.
        assert np.all(np.abs(road - (36, 49, 64)) <= 12), road
        obs, *_ = env.step(0)
        assert obs["FRONT_FACING_CAMERA"].std() > 5.0
    finally:
        env.close()


def test_a_missing_world_file_is_named(bundle, tmp_path):
    with pytest.raises(SimappWorldError, match=r"reinvent_gravel\.world does not exist.*reinvent_base\.world"):
        load_simapp_world(bundle, "gravel")
    copy = tmp_path / "bundle"
    shutil.copytree(bundle / "worlds", copy / "worlds")
    shutil.copytree(bundle / "models", copy / "models")
    with pytest.raises(SimappWorldError, match=r"model\.sdf: 'model://meshes/reinvent/reinvent_base\.dae' points to"):
        load_simapp_world(copy, "base")
