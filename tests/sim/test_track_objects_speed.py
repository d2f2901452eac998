"""What keeps an env with objects fast must not change what it computes: the vectorised projections equal the
one-point ones bit for bit, the per-episode cache of the static obstacles' params equals a fresh computation at every
step (and moves with randomised obstacles), and drawing the objects first gives the same pixels."""

from __future__ import annotations

import math

import numpy as np
import pytest

from racer.shared.sim.car.vehicle import Car
from racer.shared.sim.objects import bodies as object_bodies
from racer.shared.sim.objects.bodies import OBJECT_GEOM_GROUP, ObjectBodies, ObjectSlot
from racer.shared.sim.objects.challenge import ChallengeConfig
from racer.shared.sim.objects.moving_projection import MovingProjection
from racer.shared.sim.objects.poses import ObjectKind, ObjectPose
from racer.shared.sim.scene import mjcf as scene
from racer.shared.sim.scene._mujoco import mujoco
from racer.shared.sim.scene.mjcf import SceneSpec, build_model
from racer.shared.sim.scene.worlds import get_world
from racer.shared.sim.sensors.camera import CENTER_CAMERA, CameraRenderer
from racer.shared.sim.tracks.track import Track


def objects_ahead(slots, car_pose, offsets_m, yaw_offset):
    """One object per slot at (ahead, left) metres in the car's frame, turned `yaw_offset` from the car."""
    x, y, yaw = car_pose
    return [
        ObjectPose(
            slot.name,
            slot.kind,
            x + ahead * math.cos(yaw) - left * math.sin(yaw),
            y + ahead * math.sin(yaw) + left * math.cos(yaw),
            yaw + yaw_offset,
        )
        for slot, (ahead, left) in zip(slots, offsets_m, strict=True)
    ]


@pytest.mark.parametrize("route", ["racer_oval", "reinvent_base"])
def test_vectorised_projection_equals_the_one_point_methods(route, deepracer_data):
    track = Track.load(deepracer_data / "routes" / f"{route}.npy" if route.startswith("reinvent") else route)
    rng = np.random.default_rng(3)
    lo, hi = track.waypoints.reshape(-1, 2).min(axis=0) - 1.0, track.waypoints.reshape(-1, 2).max(axis=0) + 1.0
    points = rng.uniform(lo, hi, size=(300, 2))
    points = np.vstack((points, track.center_line[:40], track.inner_border[:20]))  # on vertices: clamped factors
    xs, ys = points[:, 0], points[:, 1]
    distances, near_xs, near_ys = track.project_points_m(xs, ys)
    inside = track.in_inner_polygon_points(xs, ys)
    for k, (x, y) in enumerate(points.tolist()):
        assert distances[k] == track.project_m(x, y)
        assert math.hypot(x - near_xs[k], y - near_ys[k]) == track.distance_from_center(x, y)
        assert inside[k] == track.in_inner_polygon(x, y)


def _fresh_object_params(track: Track, params: dict) -> tuple[list, list, list]:
    """objects_distance, objects_distance_from_center and objects_left_of_center computed one object at a time."""
    points = params["objects_location"]
    return (
        [track.project_m(x, y) for x, y in points],
        [track.distance_from_center(x, y) for x, y in points],
        [track.in_inner_polygon(x, y) ^ (not track.is_ccw) for x, y in points],
    )


@pytest.mark.parametrize(
    "challenge",
    [
        ChallengeConfig(race_type="OBJECT_AVOIDANCE", number_of_obstacles=3, randomize_obstacle_locations=True),
        ChallengeConfig(race_type="HEAD_TO_BOT", number_of_bot_cars=2, bot_car_speed_mps=0.5, is_lane_change=True),
    ],
    ids=["randomised_obstacles", "bot_cars"],
)
def test_cached_object_params_equal_a_fresh_computation_at_every_step(make_env, challenge):
    env = make_env(challenge=challenge)
    per_episode = []
    for episode in range(3):
        env.reset(seed=11 if episode == 0 else None)
        seen = []
        for _ in range(12):
            *_, terminated, truncated, info = env.step(2)
            params = info["params"]
            distance, from_center, left = _fresh_object_params(env.track, params)
            assert params["objects_distance"] == distance
            assert params["objects_distance_from_center"] == from_center
            assert params["objects_left_of_center"] == left
            seen.append(tuple(distance))
            if terminated or truncated:
                break
        per_episode.append(seen)
    if challenge.number_of_bot_cars:
        assert len(set(per_episode[0])) > 1  # the bots moved, and their params with them
    else:
        assert all(len(set(seen)) == 1 for seen in per_episode)  # static within an episode
        assert len({seen[0] for seen in per_episode}) == 3  # randomised again at every reset


def test_drawing_the_objects_first_gives_the_same_pixels(deepracer_data):
    slots = (
        ObjectSlot("obstacle_0", ObjectKind.BOX_OBSTACLE),
        ObjectSlot("bot_car_0", ObjectKind.BOT_CAR),
        ObjectSlot("bot_car_1", ObjectKind.BOT_CAR),
    )
    track = Track.load(deepracer_data / "routes" / "reinvent_base.npy")
    model = build_model(SceneSpec(track, get_world("base"), 1.0 / 240.0, ((CENTER_CAMERA, 0.0),), object_slots=slots))
    data = mujoco.MjData(model)
    car, bodies = Car(model), ObjectBodies(model, slots)
    plain, objects_first = CameraRenderer(model), CameraRenderer(model, front_groups=(OBJECT_GEOM_GROUP,))
    try:
        differing = 0
        for ndist in (0.02, 0.3, 0.55, 0.8):
            x, y, yaw = track.pose_at(ndist)
            car.teleport(model, data, x, y, yaw)
            ahead = [(0.6, 0.15), (1.2, -0.2), (2.5, 0.1)]
            bodies.place(data, objects_ahead(slots, (x, y, yaw), ahead, yaw_offset=0.3))
            frame = plain.rgb(data, CENTER_CAMERA).copy()
            differing += int(np.count_nonzero(frame != objects_first.rgb(data, CENTER_CAMERA)))
            bodies.place(data, [])
            assert np.count_nonzero(frame != plain.rgb(data, CENTER_CAMERA)) > 500  # the objects were in view
        assert differing == 0
    finally:
        plain.close()
        objects_first.close()


def _bot_car_as_primitives(slot: ObjectSlot) -> list[str]:
    """The reference shape: the bot car's three boxes and four wheels as MuJoCo boxes and cylinders (12 slices)."""
    common = f'contype="0" conaffinity="0" group="{OBJECT_GEOM_GROUP}" mass="0"'
    body = f'material="{object_bodies._material_name(slot, "body")}"'
    wheels = f'material="{object_bodies._material_name(slot, "wheels")}"'
    geoms = [
        f'<geom type="box" size="{hx} {hy} {hz}" pos="{x} 0 {z}" {body} {common}/>'
        for (x, z), (hx, hy, hz) in object_bodies._BOT_BOXES
    ]
    for axle_x, half_track in zip(object_bodies.BOT_AXLES_X_M, object_bodies.BOT_HALF_TRACK_M, strict=True):
        for side in (1, -1):
            geoms.append(
                f'<geom type="cylinder" size="{object_bodies.BOT_WHEEL_RADIUS_M} {object_bodies.BOT_WHEEL_HALF_WIDTH_M}" '
                f'pos="{axle_x} {side * half_track} {object_bodies.BOT_WHEEL_RADIUS_M}" '
                f'quat="0.70710678 0.70710678 0 0" {wheels} {common}/>'
            )
    return geoms


def test_the_bot_car_meshes_draw_the_boxes_and_wheels_they_replace(deepracer_data, monkeypatch):
    """Two meshes per bot car instead of seven geoms: the camera's frames differ by at most one grey level."""
    slots = tuple(ObjectSlot(f"bot_car_{i}", ObjectKind.BOT_CAR) for i in range(2))
    track = Track.load(deepracer_data / "routes" / "reinvent_base.npy")
    spec = SceneSpec(track, get_world("base"), 1.0 / 240.0, ((CENTER_CAMERA, 0.0),), object_slots=slots)
    meshes = build_model(spec)
    with monkeypatch.context() as patch:
        patch.setattr(object_bodies, "_geoms_xml", _bot_car_as_primitives)
        patch.setattr(scene, "render_quality_attributes", lambda slots: ' numslices="12" numstacks="4" numquads="1"')
        primitives = build_model(spec)
    assert meshes.ngeom == primitives.ngeom - 2 * 5
    frames = []
    for model in (meshes, primitives):
        data, car, bodies, camera = mujoco.MjData(model), Car(model), ObjectBodies(model, slots), CameraRenderer(model)
        try:
            for ndist, yaw_offset in ((0.02, 0.4), (0.4, -0.8), (0.7, 2.0)):
                x, y, yaw = track.pose_at(ndist)
                car.teleport(model, data, x, y, yaw)
                placed = [(0.5, 0.12), (1.3, -0.15)]
                bodies.place(data, objects_ahead(slots, (x, y, yaw), placed, yaw_offset=yaw_offset))
                frames.append(camera.rgb(data, CENTER_CAMERA).astype(int))
        finally:
            camera.close()
    with_meshes, with_primitives = np.array(frames[:3]), np.array(frames[3:])
    assert np.count_nonzero((with_primitives < 60).all(axis=-1)) > 3000  # dark bot cars fill much of the frames
    assert np.abs(with_meshes - with_primitives).max() <= 1


@pytest.mark.parametrize("route", ["racer_oval", "reinvent_base", "Straight_track"])
def test_moving_projection_equals_a_full_search_and_mostly_skips_it(route, deepracer_data):
    """Points driving along both lanes in 3 cm steps with some sideways wobble and a few jumps across the track."""
    track = Track.load(route if route.startswith("racer") else deepracer_data / "routes" / f"{route}.npy")
    projection = MovingProjection(track, 2)
    rng = np.random.default_rng(5)
    steps = 400
    start = rng.uniform(0.0, track.length_m, size=2)
    calls = 0
    for step in range(steps):
        xs, ys = [], []
        for k, lane in enumerate(("inner", "outer")):
            ndist = ((start[k] + 0.033 * step) / track.length_m) % 1.0
            if step % 150 == 149:
                ndist = rng.uniform()  # a jump: the window must notice
            x, y, _ = track.pose_at(ndist, lane)
            xs.append(x + rng.normal(0.0, 0.01))
            ys.append(y + rng.normal(0.0, 0.01))
        distances, near_xs, near_ys = projection.project(xs, ys)
        calls += 2
        for x, y, d, cx, cy in zip(xs, ys, distances, near_xs, near_ys, strict=True):
            assert d == track.project_m(x, y)
            assert math.hypot(x - cx, y - cy) == track.distance_from_center(x, y)
    assert projection.full_searches < calls / 4
