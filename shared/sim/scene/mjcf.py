"""Generating the MuJoCo model (MJCF) of one route in one world: floor, road, markings, light, sky and the car.

The road, its white border lines and the dashed centre line are flat visual meshes built from the route's rows
(no collision: the tyres roll on the floor plane, whose friction is the world's).
Rendering cost matters (software OpenGL, one frame per env step), so: no shadows and no multisampling (with
llvmpipe they cost 30-60x the frame), no skybox (walls instead), and the floor plane is drawn as one quad
(MuJoCo subdivides planes by their third size value for lighting; a 0.1 m grid made the frame twice as slow).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from racer.shared.sim.car import vehicle as car_geometry
from racer.shared.sim.generations.looks import LOOK_SIMAPP6, GenerationLook
from racer.shared.sim.objects.bodies import (
    ObjectSlot,
    object_bodies_mjcf,
    object_materials_mjcf,
    render_quality_attributes,
)
from racer.shared.sim.scene import world_look
from racer.shared.sim.scene._mujoco import mujoco
from racer.shared.sim.scene.simapp_world import SimappWorld, simapp_scene_xml
from racer.shared.sim.scene.worlds import World
from racer.shared.sim.tracks.track import Track

ROAD_Z_M = 0.0008
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
    simapp: SimappWorld | None = field(default=None, compare=False)
    """DeepRacer's own world meshes and lights to draw instead of racer's look (`EnvConfig.simapp_dir`)."""
    object_slots: tuple[ObjectSlot, ...] = ()
    """One mocap body per obstacle or bot car (`objects/bodies.py`), moved by `ObjectBodies.place` every step."""
    car_dynamics: car_geometry.CarDynamics = car_geometry.GAZEBO_DYNAMICS
    """The car's yaw inertia and steering servo (compiled in); its tyres are `Car`'s (`EnvConfig.car_dynamics`)."""
    look: GenerationLook = LOOK_SIMAPP6
    """The generation's lights, walls and sky (`EnvConfig.look`); the camera mount is `camera_pos_m`."""
    camera_pitch_down_rad: float = car_geometry.CAMERA_PITCH_DOWN_RAD


def _floats(values: np.ndarray) -> str:
    return " ".join(f"{v:.6f}" for v in np.asarray(values, dtype=np.float64).ravel())


def _mesh_xml(name: str, vertices: np.ndarray, faces: np.ndarray, texcoord: np.ndarray) -> str:
    return (
        f'    <mesh name="{name}" inertia="shell" vertex="{_floats(vertices)}" '
        f'face="{" ".join(str(int(i)) for i in faces.ravel())}" texcoord="{_floats(texcoord)}"/>'
    )


def _unit(vectors: np.ndarray) -> np.ndarray:
    return vectors / np.maximum(np.linalg.norm(vectors, axis=1, keepdims=True), 1e-9)


def _road_band_mesh(track: Track) -> tuple[str, float]:
    """One textured strip from ROAD_MARGIN_M outside one road edge to as far outside the other.

    u runs across the band (0 at the outer side, 1 at the inner side), v along the centre line in road-texture
    tiles, so lines and dashes come from the texture. A loop's closing row is kept (no wrap-around quad), so v
    grows all the way round. Returns the mesh and the mean road width.
    """
    rows = track.waypoints
    center, inner, outer = rows[:, 0:2], rows[:, 2:4], rows[:, 4:6]
    width_m = float(np.mean(np.linalg.norm(inner - outer, axis=1)))
    outside = outer + _unit(outer - center) * world_look.ROAD_MARGIN_M
    inside = inner + _unit(inner - center) * world_look.ROAD_MARGIN_M
    n = len(rows)
    vertices = np.empty((2 * n, 3))
    vertices[0::2, :2] = outside
    vertices[1::2, :2] = inside
    vertices[:, 2] = ROAD_Z_M
    along_m = np.concatenate(([0.0], np.cumsum(np.linalg.norm(np.diff(center, axis=0), axis=1))))
    texcoord = np.empty((2 * n, 2))
    texcoord[0::2, 0], texcoord[1::2, 0] = 0.0, 1.0
    texcoord[0::2, 1] = texcoord[1::2, 1] = along_m / world_look.road_tile_length_m()
    quads = np.arange(n - 1)
    a, b, c, d = 2 * quads, 2 * quads + 1, 2 * quads + 2, 2 * quads + 3
    faces = np.concatenate([np.stack([a, b, d], 1), np.stack([a, d, c], 1)])
    # Make every triangle face up so it is lit and not culled.
    p = vertices[faces]
    edge_1, edge_2 = p[:, 1, :2] - p[:, 0, :2], p[:, 2, :2] - p[:, 0, :2]
    normal_z = edge_1[:, 0] * edge_2[:, 1] - edge_1[:, 1] * edge_2[:, 0]
    faces[normal_z < 0] = faces[normal_z < 0][:, [0, 2, 1]]
    return _mesh_xml("road", vertices, faces, texcoord), width_m


def _walls_mesh(lo: np.ndarray, hi: np.ndarray, height_m: float) -> str:
    """Four inward-facing wall quads around the floor rectangle; v runs from the foot (0) to the top (1)."""
    corners = np.array([[lo[0], lo[1]], [hi[0], lo[1]], [hi[0], hi[1]], [lo[0], hi[1]]])
    vertices, texcoord, faces = [], [], []
    for k in range(4):
        p, q = corners[k], corners[(k + 1) % 4]
        base = len(vertices)
        vertices += [(*p, 0.0), (*q, 0.0), (*q, height_m), (*p, height_m)]
        texcoord += [(0.0, 1.0), (1.0, 1.0), (1.0, 0.0), (0.0, 0.0)]
        # Corners run counter-clockwise seen from above, so (p, top, q) winds towards the inside.
        faces += [(base, base + 2, base + 1), (base, base + 3, base + 2)]
    return _mesh_xml("walls", np.array(vertices), np.array(faces), np.array(texcoord))


def _lights_xml(lighting: world_look.Lighting) -> str:
    lights = world_look.default_lights(lighting)
    sun, point = lights["sun"], lights["point"]
    ambient = lighting.render_scale * lighting.ambient
    px, py, pz = lighting.point_pos_m
    return (
        f'    <light name="sun" type="directional" castshadow="false" pos="0 0 15" '
        f'dir="{_floats(lighting.sun_direction)}"\n'
        f'           diffuse="{_floats(sun.diffuse)}" ambient="{ambient} {ambient} {ambient}" specular="0 0 0"/>\n'
        # A spot light straight down with a 90 degree cutoff and no falloff lights everything below it as the
        # SimApp's point light does (MuJoCo's renderer draws no light of type "point").
        f'    <light name="point" type="spot" cutoff="90" exponent="0" dir="0 0 -1" castshadow="false" '
        f'pos="{px} {py} {pz}" diffuse="{_floats(point.diffuse)}"\n'
        f'           attenuation="{_floats(point.attenuation)}" ambient="0 0 0" specular="0 0 0"/>'
    )


def _racer_visuals(spec: SceneSpec, lo: np.ndarray, hi: np.ndarray) -> tuple[str, str, str, dict[str, bytes]]:
    """racer's own look of the world, or of the track where its SimApp world has one (`track_looks.py`):
    (asset elements, geoms, lights, texture files)."""
    look = spec.look.world_look(spec.track.name, spec.world.name)
    lighting = spec.look.lighting
    road_mesh, width_m = _road_band_mesh(spec.track)
    tile = world_look.FIELD_TILE_M
    assets_xml = f"""    <texture name="field_tex" type="2d" file="field.png"/>
    <texture name="road_tex" type="2d" file="road.png"/>
    <texture name="wall_tex" type="2d" file="wall.png"/>
    <material name="ground" texture="field_tex" texrepeat="{1 / tile} {1 / tile}" texuniform="true" specular="0"
              shininess="0"/>
    <material name="road" texture="road_tex" specular="0" shininess="0"/>
    <material name="walls" texture="wall_tex" specular="0" shininess="0"/>
{road_mesh}
{_walls_mesh(lo, hi, look.wall_height_m + world_look.WALL_EXTENSION_M)}"""
    geoms_xml = """    <geom name="road" type="mesh" mesh="road" material="road" contype="0" conaffinity="0" group="1"/>
    <geom name="walls" type="mesh" mesh="walls" material="walls" contype="0" conaffinity="0" group="0"/>"""
    files = {
        "field.png": world_look.field_texture_png(look, lighting=lighting),
        "road.png": world_look.road_texture_png(look, round(width_m, 4), lighting=lighting),
        "wall.png": world_look.wall_texture_png(look),
    }
    return assets_xml, geoms_xml, _lights_xml(lighting), files


def scene_mjcf_and_assets(spec: SceneSpec) -> tuple[str, dict[str, bytes]]:
    """The MJCF text and the texture files (PNG bytes by file name) it refers to."""
    track, world = spec.track, spec.world
    look = spec.look.world_look(track.name, world.name)
    lo = np.min(track.waypoints.reshape(-1, 3, 2), axis=(0, 1)) - look.field_margin_m
    hi = np.max(track.waypoints.reshape(-1, 3, 2), axis=(0, 1)) + look.field_margin_m
    mid, half = (lo + hi) / 2, (hi - lo) / 2
    if spec.simapp is None:
        assets_xml, geoms_xml, lights_xml, files = _racer_visuals(spec, lo, hi)
        floor_look = 'material="ground" group="1"'
    else:
        assets_xml, geoms_xml, lights_xml, files = simapp_scene_xml(spec.simapp, world_look.LIGHT_SCALE)
        floor_look = 'rgba="0 0 0 0" group="3"'  # physics only: DeepRacer's own field mesh is what the camera sees
    mu = world.tyre_friction
    xml = f"""<mujoco model="racer_{track.name}_{world.name}">
  <compiler angle="radian" autolimits="true"/>
  <option timestep="{spec.timestep_s!r}" integrator="implicitfast"/>
  <statistic extent="{SCENE_EXTENT_M}" center="{mid[0]:.4f} {mid[1]:.4f} 0"/>
  <visual>
    <global offwidth="640" offheight="480"/>
    <quality shadowsize="0" offsamples="0"{render_quality_attributes(spec.object_slots)}/>
    <map znear="{NEAR_CLIP_M / SCENE_EXTENT_M}" zfar="{FAR_CLIP_M / SCENE_EXTENT_M}"/>
    <headlight active="0" diffuse="0 0 0" ambient="0 0 0" specular="0 0 0"/>
  </visual>
  <asset>
{assets_xml}
{object_materials_mjcf(spec.object_slots)}
  </asset>
  <worldbody>
{lights_xml}
    <geom name="floor" type="plane" pos="{mid[0]:.4f} {mid[1]:.4f} 0" size="{half[0]:.3f} {half[1]:.3f} {2 * max(half):.3f}"
          {floor_look} friction="{mu} 0.005 0.0001" contype="1" conaffinity="2"/>
{geoms_xml}
{object_bodies_mjcf(spec.object_slots)}
{car_geometry.car_mjcf(mu, spec.camera_names, spec.camera_pos_m, spec.car_dynamics, spec.camera_pitch_down_rad)}
  </worldbody>
{car_geometry.car_actuators_mjcf(spec.car_dynamics)}
</mujoco>
"""
    return xml, files


def build_model(spec: SceneSpec) -> mujoco.MjModel:
    """Compile the scene; a compile error names the track and world."""
    try:
        xml, files = scene_mjcf_and_assets(spec)
        return mujoco.MjModel.from_xml_string(xml, assets=files)
    except ValueError as exc:
        raise ValueError(
            f"building the MuJoCo scene for track {spec.track.source} in world {spec.world.name!r} failed: {exc}"
        ) from exc
