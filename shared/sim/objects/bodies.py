"""Obstacles and bot cars as MuJoCo bodies: what the cameras draw and the LIDAR hits (the track-object logic moves them).

One mocap body per `ObjectSlot`, compiled into the scene (`SceneSpec.object_slots`). Its geoms are in group 2,
which the cameras draw and the LIDAR's rays see, and collide with nothing (contype/conaffinity 0): crashes are the
track-object logic's rectangle test, as in the SimApp. Looks, from the SimApp's models (`bundle/models/*/model.sdf`):

* box_obstacle: a plain brown box (#7b614f) 0.4 m along its heading, 0.3 m across, 0.25 m high. Its collision
  rectangle (`objects.poses.BOX_OBSTACLE_SIZE`, 0.5 x 0.4 m) is the box plus the SimApp's 0.1 m buffer.
* bot_car: DeepRacer's car (the `car_body_link_v3` shell, dark grey 0x28, and four wheels), drawn as boxes and
  12-sided wheels that follow the shell mesh's outline: a low body over the full length and width, a narrower upper
  body and the sensor tower at the front, which is what a LIDAR 0.16 m above the floor hits. They are two meshes
  (body, wheels; `objects/meshes.py`): two draws per car instead of seven.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from racer.shared.sim.objects.meshes import MeshBuilder
from racer.shared.sim.objects.poses import BOT_CAR_SIZE, BOX_OBSTACLE_SIZE, ObjectKind, ObjectPose
from racer.shared.sim.scene._mujoco import mujoco

OBJECT_GEOM_GROUP = 2
"""A group the cameras draw and the LIDAR sees (with the walls' group 0); nothing else in the scene uses it, so a
view can leave the objects out (the evaluation's top-view background)."""
MATERIAL_PREFIX = "race_object/"
OBSTACLE_NAME_PREFIX = "obstacle"
"""The SimApp's name prefix of static obstacles (`obstacle_<i>`), the ones its domain randomisation recolours."""
PARK_Z_M = -100.0
"""Where an unused slot waits: below the floor, beyond every camera's far clip (60 m) and the LIDAR's range."""
PARK_SPACING_M = 1.0

BOX_BUFFER_M = 0.1
"""The SimApp's collision rectangle is the box plus 0.1 m in each direction (`ObstacleDimensions`)."""
BOX_LENGTH_M = BOX_OBSTACLE_SIZE.length_m - BOX_BUFFER_M
BOX_WIDTH_M = BOX_OBSTACLE_SIZE.width_m - BOX_BUFFER_M
BOX_HEIGHT_M = 0.25
"""`models/box_obstacle/model.sdf`: box 0.4 x 0.3 x 0.25 m."""
BOX_RGB = (0.482, 0.38, 0.309)
OBJECT_EMISSION = 0.215
"""The SDF materials set ambient = diffuse, so Gazebo's scene ambient (0.5) lights every face of them; racer's light,
calibrated on the world meshes (whose ambient is 0), gives 0.57 x 0.5 = 0.285. Emission adds the rest, so a face
turned away from the sun shows about half its colour, as in Gazebo, instead of under a third."""

BOT_BODY_RGB = (0.156, 0.156, 0.156)
BOT_WHEEL_RGB = (0.1, 0.1, 0.1)
BOT_WHEEL_RADIUS_M = 0.036
BOT_WHEEL_HALF_WIDTH_M = 0.017
BOT_AXLES_X_M = (-0.081663, 0.082311)
BOT_HALF_TRACK_M = (0.08105, 0.079601)
BOT_HEIGHT_M = 0.205
"""Top of the shell's sensor tower (`car_body_link_v3.STL`)."""
_BOT_HALF_LENGTH_M = BOT_CAR_SIZE.length_m / 2
_BOT_HALF_WIDTH_M = BOT_CAR_SIZE.width_m / 2 - 0.004  # the wheels stick out 4 mm past the shell
BOT_BODY_MESH = "race_object/bot_car_body"
BOT_WHEELS_MESH = "race_object/bot_car_wheels"
_BOT_BOXES = (
    # (centre x, z), (half x, y, z): shell outline at heights 0.02-0.10, 0.10-0.175 and 0.175-0.205 m
    ((0.004, 0.0625), (_BOT_HALF_LENGTH_M - 0.003, _BOT_HALF_WIDTH_M, 0.0375)),
    ((0.05, 0.1375), (0.11, 0.066, 0.0375)),
    ((0.1225, 0.19), (0.0325, 0.04, 0.015)),
)


def drawn_size(kind: ObjectKind) -> tuple[float, float, float]:
    """(length along the heading, width, height) in metres of what the scene draws: the box, or the bot car's
    overall outline (its collision rectangle, up to the top of the sensor tower)."""
    if kind is ObjectKind.BOX_OBSTACLE:
        return BOX_LENGTH_M, BOX_WIDTH_M, BOX_HEIGHT_M
    return BOT_CAR_SIZE.length_m, BOT_CAR_SIZE.width_m, BOT_HEIGHT_M


@dataclass(frozen=True)
class ObjectSlot:
    """A place in the compiled scene for one track object, matched to `ObjectPose.name` at every `place()`."""

    name: str
    kind: ObjectKind


def _rgba(rgb: tuple[float, float, float]) -> str:
    return f"{rgb[0]} {rgb[1]} {rgb[2]} 1"


def body_name(index: int) -> str:
    return f"race_object_{index}"


def _material_name(slot: ObjectSlot, part: str) -> str:
    return f"{MATERIAL_PREFIX}{slot.name}/{part}"


def _parts(kind: ObjectKind) -> tuple[tuple[str, tuple[float, float, float]], ...]:
    """(part, colour) of each material an object of this kind uses."""
    if kind is ObjectKind.BOX_OBSTACLE:
        return (("body", BOX_RGB),)
    return (("body", BOT_BODY_RGB), ("wheels", BOT_WHEEL_RGB))


def _geoms_xml(slot: ObjectSlot) -> list[str]:
    """The geoms of one object in its body frame (origin on the floor at the object's centre, x along its heading)."""
    common = f'contype="0" conaffinity="0" group="{OBJECT_GEOM_GROUP}" mass="0"'
    body = f'material="{_material_name(slot, "body")}"'
    if slot.kind is ObjectKind.BOX_OBSTACLE:
        half = (BOX_LENGTH_M / 2, BOX_WIDTH_M / 2, BOX_HEIGHT_M / 2)
        return [f'<geom type="box" size="{half[0]} {half[1]} {half[2]}" pos="0 0 {half[2]}" {body} {common}/>']
    wheels = f'material="{_material_name(slot, "wheels")}"'
    return [
        f'<geom type="mesh" mesh="{BOT_BODY_MESH}" {body} {common}/>',
        f'<geom type="mesh" mesh="{BOT_WHEELS_MESH}" {wheels} {common}/>',
    ]


def bot_car_meshes() -> tuple[MeshBuilder, MeshBuilder]:
    """(body, wheels) of a bot car in its body frame: the shell's three boxes, the four wheels."""
    body, wheels = MeshBuilder(), MeshBuilder()
    for (x, z), half in _BOT_BOXES:
        body.box((x, 0.0, z), half)
    for axle_x, half_track in zip(BOT_AXLES_X_M, BOT_HALF_TRACK_M, strict=True):
        for side in (1, -1):
            wheels.wheel((axle_x, side * half_track, BOT_WHEEL_RADIUS_M), BOT_WHEEL_RADIUS_M, BOT_WHEEL_HALF_WIDTH_M)
    return body, wheels


def obstacle_materials(model: mujoco.MjModel) -> list[np.ndarray]:
    """Material ids of each static obstacle (slot names `obstacle_<i>`, the SimApp's prefix; box or parked bot car),
    one array per obstacle: what `ENABLE_DOMAIN_RANDOMIZATION` recolours at each episode, as the SimApp's
    `ModelVisualRandomizer` does for its obstacles (one colour per obstacle, bot cars driving their lane keep theirs)."""
    groups: dict[str, list[int]] = {}
    for material in range(model.nmat):
        name = model.material(material).name
        if name.startswith(MATERIAL_PREFIX + OBSTACLE_NAME_PREFIX):
            groups.setdefault(name.rsplit("/", 1)[0], []).append(material)
    return [np.array(ids) for _, ids in sorted(groups.items())]


def _check_slots(slots: Sequence[ObjectSlot]) -> None:
    names = [slot.name for slot in slots]
    duplicates = sorted({name for name in names if names.count(name) > 1})
    if duplicates:
        raise ValueError(f"object slots must have distinct names; repeated: {duplicates}")


def _park_position(index: int) -> tuple[float, float, float]:
    return (index * PARK_SPACING_M, 0.0, PARK_Z_M)


def render_quality_attributes(slots: Sequence[ObjectSlot]) -> str:
    """Extra `<quality>` attributes for a scene with objects: box faces drawn as one quad instead of 4 x 4 (the
    same pixels at 160x120, fewer triangles for llvmpipe). The bot cars are meshes (`objects/meshes.py`), which this
    does not touch. Empty without slots, so a time trial's model is unchanged."""
    return ' numquads="1"' if slots else ""


def object_materials_mjcf(slots: Sequence[ObjectSlot]) -> str:
    """Asset elements for the objects' colours, one set per slot so that each obstacle can be recoloured alone, and
    the bot car's meshes when a slot is a bot car (none without slots, so a time trial's model is unchanged)."""
    materials = [
        f'    <material name="{_material_name(slot, part)}" rgba="{_rgba(rgb)}" emission="{OBJECT_EMISSION}" '
        'specular="0" shininess="0"/>'
        for slot in slots
        for part, rgb in _parts(slot.kind)
    ]
    if any(slot.kind is ObjectKind.BOT_CAR for slot in slots):
        body, wheels = bot_car_meshes()
        materials += [body.mjcf(BOT_BODY_MESH), wheels.mjcf(BOT_WHEELS_MESH)]
    return "\n".join(materials)


def object_bodies_mjcf(slots: Sequence[ObjectSlot]) -> str:
    """Worldbody elements: one parked mocap body per slot."""
    _check_slots(slots)
    bodies = []
    for index, slot in enumerate(slots):
        x, y, z = _park_position(index)
        geoms = "\n".join(f"      {geom}" for geom in _geoms_xml(slot))
        bodies.append(f'    <body name="{body_name(index)}" mocap="true" pos="{x} {y} {z}">\n{geoms}\n    </body>')
    return "\n".join(bodies)


class ObjectBodies:
    """Moves the slots' mocap bodies to the track objects' poses; cheap enough for every env step.

    `place()` also writes the bodies' and geoms' world poses, so the camera and the LIDAR see the objects at once,
    whether it runs before or after `mj_step` (whose kinematics come first). It takes them from `mj_kinematics` on a
    private `MjData` (a few microseconds for the whole model): the env's own data keeps the car's poses as `mj_step`
    left them.
    """

    def __init__(self, model: mujoco.MjModel, slots: Sequence[ObjectSlot]) -> None:
        _check_slots(slots)
        self.slots = tuple(slots)
        self._model = model
        self._index = {slot.name: i for i, slot in enumerate(self.slots)}
        n = len(self.slots)
        try:
            body_ids = [model.body(body_name(i)).id for i in range(n)]
        except KeyError as exc:
            raise ValueError(f"the model has no bodies for these {n} object slots (build it with them): {exc}") from exc
        mocap_ids = [int(model.body_mocapid[body]) for body in body_ids]
        geom_ids = []
        for body in body_ids:
            start = int(model.body_geomadr[body])
            geom_ids.extend(range(start, start + int(model.body_geomnum[body])))
        # object_bodies_mjcf writes the bodies one after another, so bodies, mocap ids and geoms are ranges.
        self._bodies = _as_range(body_ids)
        self._mocaps = _as_range(mocap_ids)
        self._geoms = _as_range(geom_ids)
        self._scratch = mujoco.MjData(model)
        self._park = self._scratch.mocap_pos[self._mocaps].copy()
        self._placed: tuple[int, tuple[ObjectPose, ...]] | None = None
        self._scratch_views = self._slot_views(self._scratch)
        self._data_views: tuple[mujoco.MjData, list[np.ndarray]] | None = None

    def _slot_views(self, data: mujoco.MjData) -> list[np.ndarray]:
        """Views of the slots' rows in `data`'s pose arrays (the arrays of an MjData never move)."""
        return [
            getattr(data, field)[rows]
            for field, rows in (
                ("mocap_pos", self._mocaps),
                ("mocap_quat", self._mocaps),
                ("xpos", self._bodies),
                ("xquat", self._bodies),
                ("xmat", self._bodies),
                ("geom_xpos", self._geoms),
                ("geom_xmat", self._geoms),
            )
        ]

    def _views_of(self, data: mujoco.MjData) -> list[np.ndarray]:
        if self._data_views is None or self._data_views[0] is not data:
            self._data_views = (data, self._slot_views(data))
        return self._data_views[1]

    def place(self, data: mujoco.MjData, objects: Sequence[ObjectPose]) -> None:
        """Put each slot's body at its object's pose (standing on the floor); slots without an object are parked."""
        objects = tuple(objects)
        views, scratch_views = self._views_of(data), self._scratch_views
        if (
            self._placed is not None
            and self._placed[0] == id(data)
            and _same_objects(self._placed[1], objects)
            and np.array_equal(views[0], scratch_views[0])
        ):
            return  # nothing moved (static obstacles): the world poses derived from mocap_pos are still right
        if not self.slots:
            if objects:
                raise ValueError(f"no object slots in this scene for {[obj.name for obj in objects]}")
            return
        pos, quat = scratch_views[0], scratch_views[1]
        pos[:] = self._park
        quat[:] = (1.0, 0.0, 0.0, 0.0)
        for obj in objects:
            i = self._index.get(obj.name)
            if i is None:
                raise ValueError(f"track object {obj.name!r} has no slot in the scene; slots: {sorted(self._index)}")
            if obj.kind is not self.slots[i].kind:
                raise ValueError(
                    f"track object {obj.name!r} is a {obj.kind.value}, its slot was built for a {self.slots[i].kind.value}"
                )
            pos[i] = (obj.x_m, obj.y_m, 0.0)
            quat[i] = (math.cos(0.5 * obj.yaw_rad), 0.0, 0.0, math.sin(0.5 * obj.yaw_rad))
        mujoco.mj_kinematics(self._model, self._scratch)
        for target, source in zip(views, scratch_views, strict=True):
            target[...] = source
        self._placed = (id(data), objects)


def _same_objects(placed: tuple[ObjectPose, ...], objects: tuple[ObjectPose, ...]) -> bool:
    """Equal poses; the track-object logic hands the same objects again while they stand, which compares fastest."""
    return len(placed) == len(objects) and all(a is b or a == b for a, b in zip(placed, objects, strict=True))


def _as_range(ids: list[int]) -> slice:
    if ids and ids != list(range(ids[0], ids[0] + len(ids))):
        raise ValueError(f"object bodies are expected one after another in the model, got ids {ids}")
    return slice(ids[0], ids[0] + len(ids)) if ids else slice(0, 0)


def slot_for(obj: ObjectPose) -> ObjectSlot:
    """The slot an object needs (same name and kind)."""
    return ObjectSlot(obj.name, obj.kind)


__all__ = ["ObjectBodies", "ObjectSlot", "object_bodies_mjcf", "slot_for", "PARK_Z_M"]
