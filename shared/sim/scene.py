"""Generating the MuJoCo model (MJCF) of one route in one world: floor, road, markings, light, sky and the car.

The road, its white border lines and the dashed centre line are flat visual meshes built from the route's rows
(no collision: the tyres roll on the floor plane, whose friction is the world's).
Rendering cost matters (software OpenGL, one frame per env step), so: no shadows and no multisampling (with
llvmpipe they cost 30-60x the frame), no skybox (walls instead), and the floor plane is drawn as one quad
(MuJoCo subdivides planes by their third size value for lighting; a 0.1 m grid made the frame twice as slow).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from racer.shared.sim import car as car_geometry
from racer.shared.sim._mujoco import mujoco
from racer.shared.sim.track import Track
from racer.shared.sim.worlds import Texture, World

ROAD_Z_M = 0.0008
LINE_Z_M = 0.0016
BORDER_LINE_WIDTH_M = 0.05
CENTER_LINE_WIDTH_M = 0.025
FLOOR_MARGIN_M = 6.0
SCENE_EXTENT_M = 10.0
"""Fixed `statistic extent` so the clip planes below are in metres times 10."""
NEAR_CLIP_M = 0.02
FAR_CLIP_M = 60.0


@dataclass(frozen=True)
class SceneSpec:
    """What a compiled scene depends on."""

    track: Track
    world: World
    timestep_s: float
    camera_names: tuple[tuple[str, float], ...]
    """(camera name, lateral offset y in metres) per camera to mount on the car."""
    camera_pos_m: tuple[float, float, float] = car_geometry.CAMERA_POS_M
    """Camera mount (x, z used; y per camera) on the car."""


def _floats(values: np.ndarray) -> str:
    return " ".join(f"{v:.6f}" for v in np.asarray(values, dtype=np.float64).ravel())


def _ring_rows(track: Track) -> np.ndarray:
    """Rows without the closing duplicate for a loop (the strip wraps around instead)."""
    return track.waypoints[:-1] if track.is_loop else track.waypoints


def _strip_mesh(
    name: str,
    left: np.ndarray,
    right: np.ndarray,
    z: float,
    closed: bool,
    quads: np.ndarray | None = None,
    uv_scale: float = 1.0,
) -> str:
    """A flat triangle strip between two polylines of equal length; `quads` selects which quads to emit."""
    n = len(left)
    vertices = np.empty((2 * n, 3))
    vertices[0::2, :2] = left
    vertices[1::2, :2] = right
    vertices[:, 2] = z
    count = n if closed else n - 1
    if quads is None:
        quads = np.arange(count)
    faces = []
    for i in quads:
        j = (i + 1) % n
        a, b, c, d = 2 * i, 2 * i + 1, 2 * j, 2 * j + 1
        faces.append((a, b, d))
        faces.append((a, d, c))
    faces_arr = np.asarray(faces, dtype=np.int64)
    # Make every triangle face up so it is lit and not culled.
    p = vertices[faces_arr]
    normal_z = (p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1]) - (p[:, 1, 1] - p[:, 0, 1]) * (p[:, 2, 0] - p[:, 0, 0])
    flip = normal_z < 0
    faces_arr[flip] = faces_arr[flip][:, [0, 2, 1]]
    texcoord = vertices[:, :2] * uv_scale
    return (
        f'    <mesh name="{name}" inertia="shell" vertex="{_floats(vertices)}" '
        f'face="{" ".join(str(int(i)) for i in faces_arr.ravel())}" texcoord="{_floats(texcoord)}"/>'
    )


def _offset_towards(border: np.ndarray, center: np.ndarray, width_m: float) -> np.ndarray:
    direction = center - border
    length = np.linalg.norm(direction, axis=1, keepdims=True)
    return border + direction / np.maximum(length, 1e-9) * width_m


def _center_line_edges(center: np.ndarray, closed: bool, half_width_m: float) -> tuple[np.ndarray, np.ndarray]:
    """Left/right edges of a thin band along the centre line (normals from central differences)."""
    if closed:
        tangent = np.roll(center, -1, axis=0) - np.roll(center, 1, axis=0)
    else:
        tangent = np.gradient(center, axis=0)
    tangent /= np.maximum(np.linalg.norm(tangent, axis=1, keepdims=True), 1e-9)
    normal = np.stack([-tangent[:, 1], tangent[:, 0]], axis=1)
    return center + normal * half_width_m, center - normal * half_width_m


def _texture_xml(name: str, texture: Texture) -> str:
    mark = f' mark="{texture.mark}" markrgb="{_floats(texture.markrgb)}" random="{texture.random}"' if texture.mark != "none" else ""
    return (
        f'    <texture name="{name}" type="2d" builtin="{texture.builtin}" rgb1="{_floats(texture.rgb1)}" '
        f'rgb2="{_floats(texture.rgb2)}" width="{texture.size_px}" height="{texture.size_px}"{mark}/>'
    )


def _backdrop_xml(mid: np.ndarray, half: np.ndarray) -> str:
    """Four untextured walls around the floor, two-toned: the horizon the camera sees (cheaper than a skybox)."""
    walls = []
    for index, (dx, dy, sx, sy) in enumerate(
        ((half[0], 0.0, 0.05, half[1]), (-half[0], 0.0, 0.05, half[1]), (0.0, half[1], half[0], 0.05), (0.0, -half[1], half[0], 0.05))
    ):
        for level, (z, hz, material) in enumerate(((0.6, 0.6, "wall_low"), (3.2, 2.0, "wall_high"))):
            walls.append(
                f'    <geom name="wall_{index}_{level}" type="box" pos="{mid[0] + dx:.3f} {mid[1] + dy:.3f} {z}" '
                f'size="{sx:.3f} {sy:.3f} {hz}" material="{material}" contype="0" conaffinity="0" group="1"/>'
            )
    return "\n".join(walls)


def scene_mjcf(spec: SceneSpec) -> str:
    track, world = spec.track, spec.world
    rows = _ring_rows(track)
    closed = track.is_loop
    center, inner, outer = rows[:, 0:2], rows[:, 2:4], rows[:, 4:6]
    lo = np.min(track.waypoints.reshape(-1, 3, 2), axis=(0, 1))
    hi = np.max(track.waypoints.reshape(-1, 3, 2), axis=(0, 1))
    mid = (lo + hi) / 2
    half = (hi - lo) / 2 + FLOOR_MARGIN_M
    dash_quads = np.arange(0, len(rows) if closed else len(rows) - 1, 2)
    c_left, c_right = _center_line_edges(center, closed, CENTER_LINE_WIDTH_M / 2)
    meshes = "\n".join(
        (
            _strip_mesh("road", outer, inner, ROAD_Z_M, closed, uv_scale=world.road.repeat_per_m),
            _strip_mesh("inner_line", inner, _offset_towards(inner, center, BORDER_LINE_WIDTH_M), LINE_Z_M, closed),
            _strip_mesh("outer_line", outer, _offset_towards(outer, center, BORDER_LINE_WIDTH_M), LINE_Z_M, closed),
            _strip_mesh("center_line", c_left, c_right, LINE_Z_M, closed, quads=dash_quads),
        )
    )
    light = world.lighting
    sky1, sky2 = world.skybox_rgb
    mu = world.tyre_friction
    ground_repeat = world.ground.repeat_per_m
    return f"""<mujoco model="racer_{track.name}_{world.name}">
  <compiler angle="radian" autolimits="true"/>
  <option timestep="{spec.timestep_s!r}" integrator="implicitfast"/>
  <statistic extent="{SCENE_EXTENT_M}" center="{mid[0]:.4f} {mid[1]:.4f} 0"/>
  <visual>
    <global offwidth="640" offheight="480"/>
    <quality shadowsize="0" offsamples="0"/>
    <map znear="{NEAR_CLIP_M / SCENE_EXTENT_M}" zfar="{FAR_CLIP_M / SCENE_EXTENT_M}"/>
    <headlight diffuse="{_floats(light.headlight_diffuse)}" ambient="{_floats(light.headlight_ambient)}" specular="0 0 0"/>
  </visual>
  <asset>
{_texture_xml("ground_tex", world.ground)}
{_texture_xml("road_tex", world.road)}
    <material name="ground" texture="ground_tex" texrepeat="{ground_repeat} {ground_repeat}" texuniform="true" specular="0" shininess="0"/>
    <material name="road" texture="road_tex" specular="0.05" shininess="0"/>
    <material name="border" rgba="{_floats(world.border_rgb)} 1" specular="0"/>
    <material name="center" rgba="{_floats(world.center_line_rgb)} 1" specular="0"/>
    <material name="wall_low" rgba="{_floats(sky1)} 1" specular="0"/>
    <material name="wall_high" rgba="{_floats(sky2)} 1" specular="0"/>
{meshes}
  </asset>
  <worldbody>
    <light name="sun" directional="true" castshadow="false" pos="{mid[0]:.3f} {mid[1]:.3f} 10" dir="{_floats(light.direction)}"
           diffuse="{_floats(light.diffuse)}" ambient="{_floats(light.ambient)}" specular="0 0 0"/>
    <geom name="floor" type="plane" pos="{mid[0]:.4f} {mid[1]:.4f} 0" size="{half[0]:.3f} {half[1]:.3f} {2 * max(half):.3f}" material="ground"
          friction="{mu} 0.005 0.0001" contype="1" conaffinity="2" group="1"/>
    <geom name="road" type="mesh" mesh="road" material="road" contype="0" conaffinity="0" group="1"/>
    <geom name="inner_line" type="mesh" mesh="inner_line" material="border" contype="0" conaffinity="0" group="1"/>
    <geom name="outer_line" type="mesh" mesh="outer_line" material="border" contype="0" conaffinity="0" group="1"/>
    <geom name="center_line" type="mesh" mesh="center_line" material="center" contype="0" conaffinity="0" group="1"/>
{_backdrop_xml(mid, half)}
{car_geometry.car_mjcf(mu, spec.camera_names, spec.camera_pos_m)}
  </worldbody>
{car_geometry.car_actuators_mjcf()}
</mujoco>
"""


def build_model(spec: SceneSpec) -> mujoco.MjModel:
    """Compile the scene; a compile error names the track and world."""
    try:
        return mujoco.MjModel.from_xml_string(scene_mjcf(spec))
    except ValueError as exc:
        raise ValueError(f"building the MuJoCo scene for track {spec.track.source} in world {spec.world.name!r} failed: {exc}") from exc
