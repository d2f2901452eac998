"""Every world × sensor combination produces observations of the declared shape and dtype; conversions."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from racer.shared.deepracer.model_metadata import parse_model_metadata
from racer.shared.sim.config import EnvConfig
from racer.shared.sim.env import DeepRacerEnv
from racer.shared.sim.scene.worlds import WORLD_NAMES
from racer.shared.sim.sensors.camera import rgb_to_l, rgb_to_y
from racer.shared.sim.sensors.lidar import sector_bits

SENSOR_SETS = (
    ("FRONT_FACING_CAMERA",),
    ("STEREO_CAMERAS", "LIDAR"),
    ("LEFT_CAMERA", "SECTOR_LIDAR"),
    ("FRONT_FACING_CAMERA", "DISCRETIZED_SECTOR_LIDAR"),
    ("observation",),
)
EXPECTED_SHAPES = {
    "FRONT_FACING_CAMERA": ((120, 160, 1), np.uint8),
    "LEFT_CAMERA": ((120, 160, 1), np.uint8),
    "observation": ((120, 160, 1), np.uint8),
    "STEREO_CAMERAS": ((120, 160, 2), np.uint8),
    "LIDAR": ((64,), np.float32),
    "SECTOR_LIDAR": ((8,), np.float32),
    "DISCRETIZED_SECTOR_LIDAR": ((4 * 2,), np.float32),
}


def _metadata(sensors):
    data = {
        "action_space": [{"steering_angle": 0.0, "speed": 1.0}, {"steering_angle": 20.0, "speed": 1.0}],
        "sensor": list(sensors),
    }
    if "observation" in sensors:
        data = {"action_space": data["action_space"]}  # v1 models: no sensor list, camera key "observation"
    else:
        data["version"] = "4"
        data["lidar_config"] = {"num_sectors": 4, "num_values_per_sector": 2, "clipping_dist": 1.5}
    return parse_model_metadata(data)


@pytest.mark.parametrize("world", WORLD_NAMES)
@pytest.mark.parametrize("sensors", SENSOR_SETS, ids="+".join)
def test_observation_shapes(world, sensors):
    metadata = _metadata(sensors)
    env = DeepRacerEnv(EnvConfig(world=world, model_metadata=metadata))
    try:
        assert set(env.observation_space.spaces) == set(sensors)
        obs, _ = env.reset(seed=0)
        for _ in range(2):
            obs, *_ = env.step(1)
        assert env.observation_space.contains(obs)
        for key in sensors:
            shape, dtype = EXPECTED_SHAPES[key]
            assert obs[key].shape == shape and obs[key].dtype == dtype, key
        camera = next(
            k for k in sensors if k in ("FRONT_FACING_CAMERA", "STEREO_CAMERAS", "LEFT_CAMERA", "observation")
        )
        image = obs[camera]
        assert image.std() > 5.0  # the road, its markings and the floor are visible
        # Upright: the frame correlates with mujoco.Renderer's picture of the same camera, not with its mirror image.
        from racer.shared.sim.scene._mujoco import mujoco
        from racer.shared.sim.sensors.camera import rgb_to_y

        camera_name = {"LEFT_CAMERA": "left_camera", "STEREO_CAMERAS": "left_camera"}.get(camera, "front_camera")
        with mujoco.Renderer(env.model, height=120, width=160) as reference:
            reference.update_scene(env.data, camera_name)
            expected = rgb_to_y(reference.render()).astype(float)
        seen = image[..., 0].astype(float)
        assert np.corrcoef(seen.ravel(), expected.ravel())[0, 1] > 0.9
        assert np.corrcoef(seen.ravel(), expected[::-1].ravel())[0, 1] < 0.5
        if camera == "STEREO_CAMERAS":
            assert not np.array_equal(image[..., 0], image[..., 1])
    finally:
        env.close()


def test_worlds_look_different():
    """Every pair of worlds gives clearly different frames at the same pose (base and carpet have about the same
    mean grey, as in DeepRacer, so the frames are compared pixel by pixel)."""
    frames = {}
    for world in WORLD_NAMES:
        env = DeepRacerEnv(EnvConfig(world=world))
        try:
            obs, _ = env.reset(seed=0)
            frames[world] = obs["FRONT_FACING_CAMERA"][..., 0].astype(int)
        finally:
            env.close()
    names = list(frames)
    for i, first in enumerate(names):
        for second in names[i + 1 :]:
            assert np.abs(frames[first] - frames[second]).mean() > 8.0, (first, second)


def test_grayscale_conversions_match_coach_and_pil():
    rng = np.random.default_rng(0)
    rgb = rng.integers(0, 256, size=(120, 160, 3), dtype=np.uint8)
    expected_y = (0.2989 * rgb[..., 0] + 0.5870 * rgb[..., 1] + 0.1140 * rgb[..., 2]).astype(np.uint8)
    np.testing.assert_array_equal(rgb_to_y(rgb), expected_y)
    np.testing.assert_array_equal(rgb_to_l(rgb), np.asarray(Image.fromarray(rgb).convert("L")))


def test_sector_bits_one_hot_per_sector():
    ranges = np.full(64, np.inf)
    ranges[0:8] = 0.1  # sector 0: nearest bin
    ranges[8:16] = 1.2  # sector 1: 1.2 / (1.5 / 2) = 1.6 -> bin 1
    ranges[20] = 1.49  # sector 2: bin 1
    bits = sector_bits(ranges, num_sectors=8, num_values=2, clipping_dist_m=1.5)
    assert bits.shape == (16,) and bits.dtype == np.float32
    assert bits.reshape(8, 2).tolist()[:4] == [[1, 0], [0, 1], [0, 1], [0, 0]]
    assert bits.reshape(8, 2)[4:].sum() == 0
    sector = sector_bits(ranges, num_sectors=8, num_values=1, clipping_dist_m=0.5)
    assert sector.tolist() == [1, 0, 0, 0, 0, 0, 0, 0]


def test_lidar_rays_hit_group_zero_geoms_only():
    from racer.shared.sim.scene._mujoco import mujoco
    from racer.shared.sim.sensors.lidar import NUM_RAYS, Lidar

    model = mujoco.MjModel.from_xml_string(
        """<mujoco><worldbody>
        <geom name="wall_ahead" type="box" pos="0.8 0 0.16" size="0.05 0.3 0.2" group="0"/>
        <geom name="backdrop" type="box" pos="-2 0 0.16" size="0.05 3 0.2" group="1"/>
        <body name="car"><site name="lidar" pos="0 0 0.16"/></body>
        </worldbody></mujoco>"""
    )
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    ranges = Lidar(model, model.body("car").id).scan(model, data, np.random.default_rng(0))
    assert ranges.shape == (NUM_RAYS,)
    middle = NUM_RAYS // 2  # rays are ordered from -150° to +150°: the middle two straddle straight ahead
    assert ranges[middle] == pytest.approx(0.75, abs=0.05)
    assert np.isinf(ranges[0]) and np.isinf(ranges[-1])  # the backdrop behind is not seen
    assert np.isfinite(ranges).sum() >= 2


def test_grayscale_is_exact_for_every_colour():
    """All 16.7M colours: the fast converter equals RL Coach's float64 formula (256 slices of 256×256)."""
    from racer.shared.sim.sensors.camera import GrayConverter

    converter = GrayConverter((256, 256))
    g, b = np.meshgrid(np.arange(256), np.arange(256), indexing="ij")
    rgb = np.empty((256, 256, 3), dtype=np.uint8)
    rgb[..., 1], rgb[..., 2] = g, b
    for r in range(256):
        rgb[..., 0] = r
        expected = (0.2989 * rgb[..., 0] + 0.5870 * rgb[..., 1] + 0.1140 * rgb[..., 2]).astype(np.uint8)
        np.testing.assert_array_equal(converter.to_y(rgb), expected, err_msg=f"R={r}")


def test_discretized_sector_lidar_defaults_to_8_by_8_with_stereo_cameras():
    """No lidar_config: DeepRacer's default 8 sectors x 8 values (64 one-hot bits), next to the stereo pair."""
    metadata = parse_model_metadata(
        {
            "action_space": [{"steering_angle": a, "speed": 1.0} for a in (0.0, 20.0)],
            "version": "4",
            "sensor": ["STEREO_CAMERAS", "DISCRETIZED_SECTOR_LIDAR"],
        }
    )
    env = DeepRacerEnv(EnvConfig(model_metadata=metadata))
    try:
        obs, _ = env.reset(seed=0)
        obs, *_ = env.step(0)
        assert obs["DISCRETIZED_SECTOR_LIDAR"].shape == (64,) and obs["STEREO_CAMERAS"].shape == (120, 160, 2)
        bits = obs["DISCRETIZED_SECTOR_LIDAR"].reshape(8, 8)
        assert set(np.unique(bits)) <= {0.0, 1.0} and (bits.sum(axis=1) <= 1).all()  # at most one bit per sector
        assert env.observation_space.contains(obs)
    finally:
        env.close()
