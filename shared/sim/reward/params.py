"""The reward-function `params` dict, key for key and type for type as DeepRacer builds it (deepracer-simapp v5.3.3
`bundle/markov/agent_ctrl/constants.py` RewardParam,
`bundle/markov/agent_ctrl/utils.py`; `sim_time` is deepracer-simapp 01f5f015's; docs/custom-files.md lists every key).

Independent of MuJoCo on purpose: the analysis tools rebuild params from simtrace rows with the same function.
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from racer.shared.sim.objects.moving_projection import MovingProjection
from racer.shared.sim.tracks.track import PointGeometry, Track

FRONT_OF_CAR_M = 0.14
"""DeepRacer's model point: the car origin moved 0.14 m forward along the heading."""

CAMERA_HORIZONTAL_FOV_RAD = 1.13
CAMERA_OFFSET_M = 0.14529
"""Camera optical centre ahead of the car origin; used by the (2-D) object-in-camera test."""
CAMERA_NEAR_M = 0.2

PARAM_KEYS: tuple[str, ...] = (
    "all_wheels_on_track",
    "x",
    "y",
    "heading",
    "distance_from_center",
    "is_left_of_center",
    "projection_distance",
    "progress",
    "steps",
    "speed",
    "steering_angle",
    "track_width",
    "track_length",
    "waypoints",
    "closest_waypoints",
    "is_reversed",
    "is_crashed",
    "is_offtrack",
    "closest_objects",
    "objects_location",
    "objects_left_of_center",
    "object_in_camera",
    "objects_speed",
    "objects_heading",
    "objects_distance_from_center",
    "objects_distance",
    "sim_time",
)
"""Every key of the params dict; all are always present."""


@dataclass(frozen=True)
class RewardObject:
    """An obstacle or bot car as the reward params describe it."""

    x: float
    y: float
    heading_rad: float = 0.0
    speed_mps: float = 0.0
    is_bot_car: bool = False
    length_m: float = 0.0
    """Rectangle along the heading; with `width_m` its corners count for `object_in_camera` (0 = the centre only)."""
    width_m: float = 0.0


@dataclass(frozen=True)
class ObjectsOnTrack:
    """Where each object lies relative to the centre line, in object order: the track's part of the `objects_*`
    params. A static obstacle's stays the same for a whole episode, so the track-object logic computes it once per
    episode instead of per step."""

    distances_m: tuple[float, ...]
    """`objects_distance`: metres along the centre line of the object's projection."""
    distances_from_center_m: tuple[float, ...]
    left_of_center: tuple[bool, ...]

    def __add__(self, other: ObjectsOnTrack) -> ObjectsOnTrack:
        return ObjectsOnTrack(
            self.distances_m + other.distances_m,
            self.distances_from_center_m + other.distances_from_center_m,
            self.left_of_center + other.left_of_center,
        )


NO_OBJECTS_ON_TRACK = ObjectsOnTrack((), (), ())


def objects_on_track(
    track: Track, objects: Sequence[RewardObject], projection: MovingProjection | None = None
) -> ObjectsOnTrack:
    """The centre-line facts of every object (the same values as the one-point `Track` methods: `project_m`,
    `distance_from_center`, the left-of-centre test below): all objects in one vectorised projection, or through
    `projection` for objects that move a little per call (bot cars)."""
    if not objects:
        return NO_OBJECTS_ON_TRACK
    xs, ys = [o.x for o in objects], [o.y for o in objects]
    if projection is None:
        distances, near_xs, near_ys = (a.tolist() for a in track.project_points_m(np.array(xs), np.array(ys)))
    else:
        distances, near_xs, near_ys = projection.project(xs, ys)
    if track.is_loop:
        left = tuple(bool(v) ^ (not track.is_ccw) for v in track.in_inner_polygon_points(np.array(xs), np.array(ys)))
    else:
        left = tuple(track.is_left_of_center(x, y) for x, y in zip(xs, ys, strict=True))
    return ObjectsOnTrack(
        tuple(distances),
        tuple(math.hypot(x - cx, y - cy) for x, y, cx, cy in zip(xs, ys, near_xs, near_ys, strict=True)),
        left,
    )


def make_reward_params(
    track: Track,
    *,
    x: float,
    y: float,
    heading_deg: float,
    speed_mps: float,
    steering_angle_deg: float,
    steps: float,
    progress: float,
    all_wheels_on_track: bool,
    is_offtrack: bool,
    is_crashed: bool = False,
    is_reversed: bool | None = None,
    sim_time_s: float = 0.0,
    objects: Sequence[RewardObject] = (),
    geometry: PointGeometry | None = None,
    objects_track: ObjectsOnTrack | None = None,
) -> dict:
    """Build the complete params dict for one step.

    `x`, `y` are the front-of-car point (as in the simtrace X, Y). `speed_mps` / `steering_angle_deg` are the
    commanded (unclipped) action values. `is_reversed` defaults to the track's direction flag. `geometry` may pass
    a `track.point_geometry(x, y)` already computed by the caller (the env does, for progress), `objects_track` the
    `objects_on_track(track, objects)` the caller keeps (the env does, per episode for static obstacles).
    """
    if geometry is None:
        geometry = track.point_geometry(x, y)
    params = {
        "all_wheels_on_track": bool(all_wheels_on_track),
        "x": float(x),
        "y": float(y),
        "heading": float(heading_deg),
        "distance_from_center": geometry.distance_from_center_m,
        "is_left_of_center": bool(geometry.is_left_of_center),
        "projection_distance": geometry.ndist * track.length_m,
        "progress": progress,
        "steps": float(steps),
        "speed": float(speed_mps),
        "steering_angle": float(steering_angle_deg),
        "track_width": geometry.track_width_m,
        "track_length": track.length_m,
        "waypoints": track.waypoint_tuples,
        "closest_waypoints": list(geometry.closest_waypoints),
        "is_reversed": bool(track.direction_reversed if is_reversed is None else is_reversed),
        "is_crashed": bool(is_crashed),
        "is_offtrack": bool(is_offtrack),
        "sim_time": float(sim_time_s),
    }
    params.update(
        object_params(
            track, objects, x=x, y=y, heading_deg=heading_deg, car_ndist=geometry.ndist, objects_track=objects_track
        )
    )
    return {key: params[key] for key in PARAM_KEYS}


def object_params(
    track: Track,
    objects: Sequence[RewardObject],
    *,
    x: float,
    y: float,
    heading_deg: float,
    car_ndist: float,
    objects_track: ObjectsOnTrack | None = None,
) -> dict:
    """The `objects_*` keys; DeepRacer's defaults when there are no objects."""
    if not objects:
        return {
            "closest_objects": [0, 0],
            "objects_location": [],
            "objects_left_of_center": [],
            "object_in_camera": False,
            "objects_speed": [],
            "objects_heading": [],
            "objects_distance_from_center": [],
            "objects_distance": [],
        }
    if objects_track is None:
        objects_track = objects_on_track(track, objects)
    elif len(objects_track.distances_m) != len(objects):
        raise ValueError(f"objects_track covers {len(objects_track.distances_m)} objects, the step has {len(objects)}")
    distances = list(objects_track.distances_m)
    order = sorted(range(len(objects)), key=lambda i: distances[i])
    sorted_distances = [distances[i] for i in order]
    next_pos = bisect.bisect_right(sorted_distances, car_ndist * track.length_m)
    prev_pos = next_pos - 1
    if next_pos == len(order):
        next_pos = 0
    if prev_pos == -1:
        prev_pos = len(order) - 1
    prev_idx, next_idx = order[prev_pos], order[next_pos]
    any_bot = any(o.is_bot_car for o in objects)
    return {
        "closest_objects": [prev_idx, next_idx],
        "objects_location": [[float(o.x), float(o.y)] for o in objects],
        "objects_left_of_center": list(objects_track.left_of_center),
        "object_in_camera": _in_camera(objects[next_idx], x, y, heading_deg),
        "objects_speed": [float(o.speed_mps) if any_bot else 0.0 for o in objects],
        "objects_heading": [float(o.heading_rad) if any_bot else 0.0 for o in objects],
        "objects_distance_from_center": list(objects_track.distances_from_center_m),
        "objects_distance": distances,
    }


def _in_camera(obj: RewardObject, x: float, y: float, heading_deg: float) -> bool:
    """Whether the object's centre or a corner of its floor rectangle lies in the camera's horizontal field of view
    beyond the near plane (the SimApp tests the same points against its frustum; a 2-D simplification)."""
    yaw = math.radians(heading_deg)
    origin_x = x - FRONT_OF_CAR_M * math.cos(yaw)
    origin_y = y - FRONT_OF_CAR_M * math.sin(yaw)
    cam_x = origin_x + CAMERA_OFFSET_M * math.cos(yaw)
    cam_y = origin_y + CAMERA_OFFSET_M * math.sin(yaw)
    points = [(obj.x, obj.y)]
    if obj.length_m > 0 and obj.width_m > 0:
        c, s = math.cos(obj.heading_rad), math.sin(obj.heading_rad)
        half_l, half_w = obj.length_m / 2, obj.width_m / 2
        points += [
            (obj.x + c * lx - s * ly, obj.y + s * lx + c * ly)
            for lx, ly in ((half_l, half_w), (half_l, -half_w), (-half_l, -half_w), (-half_l, half_w))
        ]
    for px, py in points:
        dx, dy = px - cam_x, py - cam_y
        forward = dx * math.cos(yaw) + dy * math.sin(yaw)
        if forward < CAMERA_NEAR_M:
            continue
        bearing = math.atan2(dy, dx) - yaw
        bearing = (bearing + math.pi) % (2 * math.pi) - math.pi
        if abs(bearing) <= CAMERA_HORIZONTAL_FOV_RAD / 2:
            return True
    return False


def copy_params(params: dict) -> dict:
    """A copy a reward function may mutate freely (DeepRacer deep-copies; tuples and scalars are immutable)."""
    copied = dict(params)
    for key, value in copied.items():
        if isinstance(value, list):
            copied[key] = [list(item) for item in value] if value and isinstance(value[0], list) else list(value)
    return copied
