"""Obstacles and bot cars in a real scene: the LIDAR measures them where the geometry says, the cameras draw them."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from racer.shared.sim.car.vehicle import LIDAR_POS_M, STEREO_HALF_BASELINE_M, Car
from racer.shared.sim.objects.bodies import (
    BOX_HEIGHT_M,
    BOX_LENGTH_M,
    BOX_WIDTH_M,
    PARK_Z_M,
    ObjectBodies,
    ObjectSlot,
)
from racer.shared.sim.objects.poses import ObjectKind, ObjectPose
from racer.shared.sim.scene._mujoco import mujoco
from racer.shared.sim.scene.mjcf import SceneSpec, build_model
from racer.shared.sim.scene.worlds import get_world
from racer.shared.sim.sensors import lidar as lidar_sensor
from racer.shared.sim.sensors.camera import CENTER_CAMERA, LEFT_CAMERA, RIGHT_CAMERA, CameraRenderer
from racer.shared.sim.tracks.track import Track

SLOTS = (
    ObjectSlot("obstacle_0", ObjectKind.BOX_OBSTACLE),
    ObjectSlot("obstacle_1", ObjectKind.BOX_OBSTACLE),
    ObjectSlot("bot_car_0", ObjectKind.BOT_CAR),
)
CAMERAS = ((CENTER_CAMERA, 0.0), (LEFT_CAMERA, STEREO_HALF_BASELINE_M), (RIGHT_CAMERA, -STEREO_HALF_BASELINE_M))


class Scene:
    def __init__(self, route) -> None:
        self.track = Track.load(route)
        spec = SceneSpec(self.track, get_world("base"), 1.0 / 240.0, CAMERAS, object_slots=SLOTS)
        self.model = build_model(spec)
        self.data = mujoco.MjData(self.model)
        self.car = Car(self.model)
        self.bodies = ObjectBodies(self.model, SLOTS)
        self.camera = CameraRenderer(self.model)
        self.lidar = lidar_sensor.Lidar(self.model, self.car.body_id)
        self.car_pose = self.track.pose_at(0.05, "center")
        self.car.teleport(self.model, self.data, *self.car_pose)

    def ahead(self, distance_m: float, left_m: float = 0.0) -> tuple[float, float]:
        x, y, yaw = self.car_pose
        return (
            x + distance_m * math.cos(yaw) - left_m * math.sin(yaw),
            y + distance_m * math.sin(yaw) + left_m * math.cos(yaw),
        )

    def raw_scan(self, seed: int = 7) -> np.ndarray:
        """Ranges without the LIDAR's noise: the same draw from a twin generator is taken off again."""
        self.lidar.reset()
        ranges = self.lidar.scan(self.model, self.data, np.random.default_rng(seed)).copy()
        noise = np.random.default_rng(seed).normal(0.0, lidar_sensor.NOISE_STD_M, lidar_sensor.NUM_RAYS)
        return ranges - noise

    def frame(self, camera: str = CENTER_CAMERA) -> np.ndarray:
        return self.camera.rgb(self.data, camera).copy()


@pytest.fixture(scope="module")
def scene(deepracer_data):
    scene = Scene(deepracer_data / "routes" / "reinvent_base.npy")
    yield scene
    scene.camera.close()


def _ray_hits_rectangle(origin, directions, center, yaw, length_m, width_m) -> np.ndarray:
    """Distance along each 2-D unit ray to a rectangle (slab method in the rectangle's frame); inf when it misses."""
    c, s = math.cos(yaw), math.sin(yaw)
    to_local = np.array([[c, s], [-s, c]])
    o = to_local @ (np.asarray(origin) - np.asarray(center))
    d = directions @ to_local.T
    half = np.array([length_m / 2, width_m / 2])
    with np.errstate(divide="ignore", invalid="ignore"):
        t1, t2 = (-half - o) / d, (half - o) / d
    near = np.nanmax(np.minimum(t1, t2), axis=1)
    far = np.nanmin(np.maximum(t1, t2), axis=1)
    return np.where((near <= far) & (near > 0), near, np.inf)


def _lidar_rays(scene: Scene) -> tuple[np.ndarray, np.ndarray]:
    x, y, yaw = scene.car_pose
    origin = np.array([x + LIDAR_POS_M[0] * math.cos(yaw), y + LIDAR_POS_M[0] * math.sin(yaw)])
    angles = yaw + np.linspace(lidar_sensor.MIN_ANGLE_RAD, lidar_sensor.MAX_ANGLE_RAD, lidar_sensor.NUM_RAYS)
    return origin, np.stack([np.cos(angles), np.sin(angles)], axis=1)


def _walls_only_scan(scene: Scene) -> np.ndarray:
    """The same LIDAR pose in the same route's scene without object slots: what the rays meet besides objects."""
    model = build_model(SceneSpec(scene.track, get_world("base"), 1.0 / 240.0, CAMERAS))
    data = mujoco.MjData(model)
    car = Car(model)
    car.teleport(model, data, *scene.car_pose)
    lidar = lidar_sensor.Lidar(model, car.body_id)
    ranges = lidar.scan(model, data, np.random.default_rng(7)).copy()
    return ranges - np.random.default_rng(7).normal(0.0, lidar_sensor.NOISE_STD_M, lidar_sensor.NUM_RAYS)


@pytest.fixture(scope="module")
def walls_only(scene):
    return _walls_only_scan(scene)


def test_parked_slots_are_out_of_sight_and_the_walls_are_seen(scene, walls_only):
    scene.bodies.place(scene.data, [])
    assert np.all(scene.data.mocap_pos[:, 2] == PARK_Z_M)
    np.testing.assert_array_equal(scene.raw_scan(), walls_only)
    # The world's walls (1 m high, around the field) are what the rays meet, never the car itself.
    assert np.isfinite(walls_only).all() and walls_only.min() > 0.5


@pytest.mark.parametrize(("distance_m", "left_m", "turn_rad"), [(1.0, 0.0, 0.0), (0.7, 0.25, 0.6), (1.4, -0.3, 2.0)])
def test_lidar_measures_a_box_where_the_geometry_puts_it(scene, walls_only, distance_m, left_m, turn_rad):
    bx, by = scene.ahead(distance_m, left_m)
    box_yaw = scene.car_pose[2] + turn_rad
    scene.bodies.place(scene.data, [ObjectPose("obstacle_0", ObjectKind.BOX_OBSTACLE, bx, by, box_yaw)])
    measured = scene.raw_scan()
    origin, directions = _lidar_rays(scene)
    expected = _ray_hits_rectangle(origin, directions, (bx, by), box_yaw, BOX_LENGTH_M, BOX_WIDTH_M)
    hits = np.isfinite(expected)
    assert hits.sum() >= 3
    assert np.max(np.abs(measured[hits] - expected[hits])) < 0.01
    np.testing.assert_array_equal(measured[~hits], walls_only[~hits])  # the other rays still meet the walls


def test_lidar_sees_a_bot_cars_upper_body_and_the_observations_follow(scene):
    """A bot car 0.5 m ahead: at the LIDAR's height (0.16 m) the rays meet its upper body, 0.06 m behind its origin."""
    bx, by = scene.ahead(0.5)
    scene.bodies.place(scene.data, [ObjectPose("bot_car_0", ObjectKind.BOT_CAR, bx, by, scene.car_pose[2])])
    measured = scene.raw_scan()
    front = measured[lidar_sensor.NUM_RAYS // 2 - 1 : lidar_sensor.NUM_RAYS // 2 + 1]
    half_step = (lidar_sensor.MAX_ANGLE_RAD - lidar_sensor.MIN_ANGLE_RAD) / (lidar_sensor.NUM_RAYS - 1) / 2
    expected = (0.5 - 0.06 - LIDAR_POS_M[0]) / math.cos(half_step)
    assert np.max(np.abs(front - expected)) < 0.01
    bits = lidar_sensor.sector_bits(measured, 8, 1, 0.5)
    assert bits[3] == bits[4] == 1.0 and bits.sum() == 2.0  # the two sectors either side of straight ahead
    assert not lidar_sensor.sector_bits(_walls_only_scan(scene), 8, 1, 0.5).any()


def _project(scene: Scene, camera: str, points: np.ndarray) -> np.ndarray:
    """Pixel (column, row) of world points in a 160x120 frame of a named camera."""
    cam = scene.model.camera(camera).id
    position = scene.data.cam_xpos[cam]
    axes = scene.data.cam_xmat[cam].reshape(3, 3)  # columns: right, up, backwards
    local = (points - position) @ axes
    focal_px = 60.0 / math.tan(math.radians(scene.model.cam_fovy[cam]) / 2)
    return np.stack([80.0 + focal_px * local[:, 0] / -local[:, 2], 60.0 - focal_px * local[:, 1] / -local[:, 2]], 1)


def _box_mask(scene: Scene, camera: str, obj: ObjectPose) -> np.ndarray:
    c, s = math.cos(obj.yaw_rad), math.sin(obj.yaw_rad)
    corners = [
        (obj.x_m + c * dx - s * dy, obj.y_m + s * dx + c * dy, z)
        for dx in (-BOX_LENGTH_M / 2, BOX_LENGTH_M / 2)
        for dy in (-BOX_WIDTH_M / 2, BOX_WIDTH_M / 2)
        for z in (0.0, BOX_HEIGHT_M)
    ]
    pixels = _project(scene, camera, np.array(corners))
    mask = np.zeros((120, 160), dtype=np.uint8)
    cv2.fillConvexPoly(mask, cv2.convexHull(np.round(pixels).astype(np.int32)), 1)
    return mask


def test_a_box_in_front_of_the_camera_fills_its_projection_and_is_gone_when_parked(scene):
    scene.bodies.place(scene.data, [])
    empty = scene.frame()
    box = ObjectPose("obstacle_1", ObjectKind.BOX_OBSTACLE, *scene.ahead(1.2, 0.1), scene.car_pose[2] + 0.3)
    scene.bodies.place(scene.data, [box])
    with_box = scene.frame()
    changed = np.abs(with_box.astype(int) - empty.astype(int)).max(axis=2) > 12
    mask = _box_mask(scene, CENTER_CAMERA, box)
    inside = cv2.erode(mask, np.ones((3, 3), np.uint8)).astype(bool)
    outside = ~cv2.dilate(mask, np.ones((5, 5), np.uint8)).astype(bool)
    assert inside.sum() > 150
    assert changed[inside].mean() > 0.9
    assert changed[outside].mean() < 0.002
    red, green, blue = with_box[inside].astype(int).T
    assert np.mean((red > green) & (green > blue)) > 0.8  # brown (#7b614f), unlike the blue road or teal walls
    scene.bodies.place(scene.data, [])
    assert np.array_equal(scene.frame(), empty)


def test_stereo_eyes_both_see_the_box_with_the_disparity_of_its_distance(scene):
    scene.bodies.place(scene.data, [])
    empty = {eye: scene.frame(eye) for eye in (LEFT_CAMERA, RIGHT_CAMERA)}
    box = ObjectPose("obstacle_0", ObjectKind.BOX_OBSTACLE, *scene.ahead(0.9), scene.car_pose[2])
    scene.bodies.place(scene.data, [box])
    columns = {}
    for eye in (LEFT_CAMERA, RIGHT_CAMERA):
        changed = np.abs(scene.frame(eye).astype(int) - empty[eye].astype(int)).max(axis=2) > 12
        mask = _box_mask(scene, eye, box).astype(bool)
        assert changed[mask].mean() > 0.9, eye
        columns[eye] = np.nonzero(changed)[1].mean()
    # The left eye sees the box further right: 2 * half baseline * focal length / depth, about 9 px at 0.9 m.
    focal_px = 60.0 / math.tan(math.radians(scene.model.cam_fovy[scene.model.camera(LEFT_CAMERA).id]) / 2)
    depth_m = 0.9 - BOX_LENGTH_M / 2 - 0.145
    expected_px = 2 * STEREO_HALF_BASELINE_M * focal_px / depth_m
    assert columns[LEFT_CAMERA] - columns[RIGHT_CAMERA] == pytest.approx(expected_px, rel=0.25)


def test_a_bot_car_is_drawn(scene):
    scene.bodies.place(scene.data, [])
    empty = scene.frame()
    scene.bodies.place(
        scene.data, [ObjectPose("bot_car_0", ObjectKind.BOT_CAR, *scene.ahead(0.8), scene.car_pose[2] + 0.5)]
    )
    frame = scene.frame()
    changed = np.abs(frame.astype(int) - empty.astype(int)).max(axis=2) > 12
    assert 100 < changed.sum() < 0.3 * changed.size
    assert np.median(frame[changed].astype(int)) < 70  # a dark car on the light-blue road and mint field


def test_place_writes_the_poses_mj_kinematics_would(scene):
    objects = [
        ObjectPose("obstacle_0", ObjectKind.BOX_OBSTACLE, 1.0, 2.0, 0.4),
        ObjectPose("bot_car_0", ObjectKind.BOT_CAR, -1.5, 0.5, -2.9, 0.5),
    ]
    scene.bodies.place(scene.data, objects)
    placed = [scene.data.geom_xpos.copy(), scene.data.geom_xmat.copy(), scene.data.xpos.copy()]
    car_xpos = scene.data.xpos[scene.car.body_id].copy()
    mujoco.mj_kinematics(scene.model, scene.data)
    for before, after in zip(placed, (scene.data.geom_xpos, scene.data.geom_xmat, scene.data.xpos), strict=True):
        np.testing.assert_allclose(before, after, atol=1e-12)
    assert np.array_equal(scene.data.xpos[scene.car.body_id], car_xpos)


def test_place_refuses_unknown_or_mismatched_objects(scene):
    with pytest.raises(ValueError, match="'bot_car_7' has no slot"):
        scene.bodies.place(scene.data, [ObjectPose("bot_car_7", ObjectKind.BOT_CAR, 0.0, 0.0, 0.0)])
    with pytest.raises(ValueError, match="'obstacle_0' is a bot_car"):
        scene.bodies.place(scene.data, [ObjectPose("obstacle_0", ObjectKind.BOT_CAR, 0.0, 0.0, 0.0)])
    with pytest.raises(ValueError, match="distinct names"):
        ObjectBodies(scene.model, (SLOTS[0], SLOTS[0]))


def test_a_scene_without_slots_is_the_time_trial_scene(deepracer_data):
    track = Track.load(deepracer_data / "routes" / "reinvent_base.npy")
    plain = SceneSpec(track, get_world("base"), 1.0 / 240.0, CAMERAS)
    with_objects = SceneSpec(track, get_world("base"), 1.0 / 240.0, CAMERAS, object_slots=SLOTS)
    assert plain != with_objects  # a cache keyed on the spec tells them apart
    model = build_model(plain)
    assert model.nmocap == 0 and model.nbody == build_model(with_objects).nbody - len(SLOTS)
