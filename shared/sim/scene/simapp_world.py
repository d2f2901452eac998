"""DeepRacer's own world meshes and textures, read from a SimApp checkout, for the MuJoCo scene.

`EnvConfig(simapp_dir=...)` points at a folder laid out like the SimApp's `bundle/` (`worlds/<name>.world`,
`models/<model>/model.sdf`, `meshes/.../*.dae` with their `textures/`). For world `w` racer reads
`worlds/reinvent_<w>.world`: its scene ambient and lights, and every visual mesh of the models it includes, at the
poses the SDF gives. COLLADA units follow each file's `<unit meter=...>` and node matrices (the base mesh is in
metres, the others in centimetres scaled by 0.01 in their node matrix). Textures are converted to PNG for MuJoCo.
The meshes only line up with the route they were made for (re:Invent 2018 for the `reinvent_*` worlds).
"""

from __future__ import annotations

import io
import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from PIL import Image

COLLADA_NS = {"c": "http://www.collada.org/2005/11/COLLADASchema"}


class SimappWorldError(ValueError):
    """A SimApp world folder or file racer cannot use; the message names the file."""


@dataclass(frozen=True)
class MeshPart:
    """One textured triangle mesh in world coordinates (metres)."""

    name: str
    vertices: np.ndarray
    faces: np.ndarray
    texcoord: np.ndarray
    texture: Path | None
    rgb: tuple[float, float, float]
    """Diffuse colour when there is no texture."""


@dataclass(frozen=True)
class SimappLight:
    name: str
    directional: bool
    diffuse: tuple[float, float, float]
    position_m: tuple[float, float, float]
    direction: tuple[float, float, float]
    attenuation: tuple[float, float, float]


@dataclass(frozen=True)
class SimappWorld:
    name: str
    source: Path
    ambient: tuple[float, float, float]
    lights: tuple[SimappLight, ...]
    parts: tuple[MeshPart, ...]


def _floats(text: str | None, count: int, source: Path, what: str) -> tuple[float, ...]:
    try:
        values = tuple(float(v) for v in (text or "").split())
    except ValueError:
        raise SimappWorldError(f"{source}: {what}: {text!r} is not a list of numbers") from None
    if len(values) < count:
        raise SimappWorldError(f"{source}: {what}: expected {count} numbers, got {text!r}")
    return values[:count]


def _pose_matrix(pose: tuple[float, ...]) -> np.ndarray:
    """SDF pose x y z roll pitch yaw as a 4x4 matrix (rotation Rz(yaw) Ry(pitch) Rx(roll))."""
    x, y, z, roll, pitch, yaw = pose
    cr, sr, cp, sp, cy, sy = (
        math.cos(roll),
        math.sin(roll),
        math.cos(pitch),
        math.sin(pitch),
        math.cos(yaw),
        math.sin(yaw),
    )
    matrix = np.eye(4)
    matrix[:3, :3] = [
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [-sp, cp * sr, cp * cr],
    ]
    matrix[:3, 3] = (x, y, z)
    return matrix


def _element_pose(element: ET.Element, source: Path) -> np.ndarray:
    pose = element.find("pose")
    if pose is None or not (pose.text or "").strip():
        return np.eye(4)
    return _pose_matrix(_floats(pose.text, 6, source, "<pose>"))


def _resolve_uri(folder: Path, uri: str, source: Path) -> Path:
    if not uri.startswith("model://"):
        raise SimappWorldError(f"{source}: only model:// URIs are supported, got {uri!r}")
    path = folder / uri[len("model://") :]
    if not path.exists():
        raise SimappWorldError(f"{source}: {uri!r} points to {path}, which does not exist")
    return path


def _parse_xml(path: Path) -> ET.Element:
    try:
        return ET.parse(path).getroot()
    except ET.ParseError as error:
        raise SimappWorldError(f"{path}: not valid XML: {error}") from error
    except OSError as error:
        raise SimappWorldError(f"{path}: cannot read: {error}") from error


def load_simapp_world(folder: Path, world: str) -> SimappWorld:
    """The scene of `worlds/reinvent_<world>.world` under `folder` (a SimApp `bundle/` layout)."""
    folder = Path(folder)
    world_file = folder / "worlds" / f"reinvent_{world}.world"
    if not world_file.is_file():
        found = sorted(p.name for p in (folder / "worlds").glob("*.world")) if (folder / "worlds").is_dir() else []
        raise SimappWorldError(
            f"{world_file} does not exist; the SimApp folder must hold worlds/reinvent_<world>.world "
            f"(found: {', '.join(found) or 'no worlds/ folder'})"
        )
    root = _parse_xml(world_file)
    world_element = root.find("world")
    if world_element is None:
        raise SimappWorldError(f"{world_file}: no <world> element")
    ambient_element = world_element.find("scene/ambient")
    ambient = (
        _floats(ambient_element.text, 3, world_file, "<scene><ambient>") if ambient_element is not None else (0.4,) * 3
    )
    lights = tuple(_light(element, world_file) for element in world_element.findall("light"))
    parts: list[MeshPart] = []
    for include in world_element.findall("include"):
        uri = include.findtext("uri", "").strip()
        model_dir = _resolve_uri(folder, uri, world_file)
        model_file = model_dir / "model.sdf"
        include_pose = _element_pose(include, world_file)
        model = _parse_xml(model_file).find("model")
        if model is None:
            raise SimappWorldError(f"{model_file}: no <model> element")
        for link in model.findall("link"):
            link_pose = include_pose @ _element_pose(link, model_file)
            for visual in link.findall("visual"):
                mesh = visual.find("geometry/mesh")
                if mesh is None:
                    continue
                mesh_file = _resolve_uri(folder, mesh.findtext("uri", "").strip(), model_file)
                scale_text = mesh.findtext("scale")
                scale = np.diag([*_floats(scale_text, 3, model_file, "<scale>"), 1.0]) if scale_text else np.eye(4)
                transform = link_pose @ _element_pose(visual, model_file) @ scale
                parts.extend(read_collada(mesh_file, transform, prefix=f"{link.get('name', 'link')}_"))
    if not parts:
        raise SimappWorldError(f"{world_file}: its models have no visual meshes")
    return SimappWorld(world_element.get("name", world), world_file, ambient, lights, tuple(parts))


def _light(element: ET.Element, source: Path) -> SimappLight:
    kind = element.get("type", "point")
    pose = _element_pose(element, source)
    diffuse = _floats(element.findtext("diffuse"), 3, source, f"light {element.get('name')} <diffuse>")
    direction_text = element.findtext("direction")
    direction = _floats(direction_text, 3, source, "<direction>") if direction_text else (0.0, 0.0, -1.0)
    attenuation = element.find("attenuation")
    constant, linear, quadratic = 1.0, 0.0, 0.0
    if attenuation is not None:
        constant = float(attenuation.findtext("constant", "1"))
        linear = float(attenuation.findtext("linear", "0"))
        quadratic = float(attenuation.findtext("quadratic", "0"))
    return SimappLight(
        element.get("name", kind),
        kind == "directional",
        diffuse,
        tuple(pose[:3, 3]),
        direction,
        (constant, linear, quadratic),
    )


def _source_array(mesh: ET.Element, source_id: str, path: Path) -> np.ndarray:
    source = mesh.find(f"c:source[@id='{source_id}']", COLLADA_NS)
    if source is None:
        raise SimappWorldError(f"{path}: source {source_id!r} is missing")
    array = source.find("c:float_array", COLLADA_NS)
    accessor = source.find("c:technique_common/c:accessor", COLLADA_NS)
    stride = int(accessor.get("stride", "1")) if accessor is not None else 3
    values = np.array((array.text or "").split(), dtype=np.float64)
    return values.reshape(-1, stride)


def _node_matrix(node: ET.Element, path: Path) -> np.ndarray:
    matrix = np.eye(4)
    for child in node:
        tag = child.tag.split("}")[-1]
        if tag == "matrix":
            matrix = matrix @ np.array(_floats(child.text, 16, path, "<matrix>")).reshape(4, 4)
        elif tag == "translate":
            step = np.eye(4)
            step[:3, 3] = _floats(child.text, 3, path, "<translate>")
            matrix = matrix @ step
        elif tag == "scale":
            matrix = matrix @ np.diag([*_floats(child.text, 3, path, "<scale>"), 1.0])
        elif tag == "rotate":
            x, y, z, angle_deg = _floats(child.text, 4, path, "<rotate>")
            axis = np.array([x, y, z]) / max(np.linalg.norm([x, y, z]), 1e-12)
            angle = math.radians(angle_deg)
            k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
            step = np.eye(4)
            step[:3, :3] = np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * k @ k
            matrix = matrix @ step
    return matrix


def _material_images(root: ET.Element, path: Path) -> dict[str, tuple[Path | None, tuple[float, float, float]]]:
    """Material id -> (diffuse texture file, diffuse colour)."""
    images = {
        image.get("id"): image.findtext("c:init_from", "", COLLADA_NS).strip()
        for image in root.findall(".//c:library_images/c:image", COLLADA_NS)
    }
    effects = {}
    for effect in root.findall(".//c:library_effects/c:effect", COLLADA_NS):
        params = {p.get("sid"): p for p in effect.findall(".//c:newparam", COLLADA_NS)}
        diffuse = effect.find(".//c:diffuse", COLLADA_NS)
        texture, colour = None, (0.8, 0.8, 0.8)
        if diffuse is not None:
            tex = diffuse.find("c:texture", COLLADA_NS)
            col = diffuse.find("c:color", COLLADA_NS)
            if tex is not None:
                name = tex.get("texture")
                if name not in images and name in params:  # sampler -> surface -> image
                    surface_sid = params[name].findtext(".//c:source", "", COLLADA_NS).strip()
                    name = params.get(surface_sid, params[name]).findtext(".//c:init_from", "", COLLADA_NS).strip()
                if name in images:
                    texture = (path.parent / images[name]).resolve()
                    if not texture.is_file():
                        raise SimappWorldError(f"{path}: texture {images[name]!r} not found at {texture}")
            elif col is not None:
                colour = _floats(col.text, 3, path, "<diffuse><color>")
        effects[effect.get("id")] = (texture, colour)
    result = {}
    for material in root.findall(".//c:library_materials/c:material", COLLADA_NS):
        url = material.find("c:instance_effect", COLLADA_NS).get("url", "").lstrip("#")
        result[material.get("id")] = effects.get(url, (None, (0.8, 0.8, 0.8)))
    return result


def read_collada(path: Path, transform: np.ndarray, prefix: str = "") -> list[MeshPart]:
    """The textured triangle meshes of a COLLADA file, in metres, transformed by `transform`."""
    root = _parse_xml(path)
    unit = root.find("c:asset/c:unit", COLLADA_NS)
    metres_per_unit = float(unit.get("meter", "1")) if unit is not None else 1.0
    materials = _material_images(root, path)
    geometries = {g.get("id"): g for g in root.findall(".//c:library_geometries/c:geometry", COLLADA_NS)}
    parts: list[MeshPart] = []

    def visit(node: ET.Element, parent: np.ndarray) -> None:
        matrix = parent @ _node_matrix(node, path)
        for instance in node.findall("c:instance_geometry", COLLADA_NS):
            geometry = geometries.get(instance.get("url", "").lstrip("#"))
            if geometry is None:
                raise SimappWorldError(f"{path}: node {node.get('name')!r} uses a missing geometry")
            bindings = {
                b.get("symbol"): b.get("target", "").lstrip("#")
                for b in instance.findall(".//c:instance_material", COLLADA_NS)
            }
            parts.extend(_geometry_parts(path, geometry, matrix, bindings, materials, prefix))
        for child in node.findall("c:node", COLLADA_NS):
            visit(child, matrix)

    top = transform @ np.diag([metres_per_unit] * 3 + [1.0])
    for node in root.findall(".//c:library_visual_scenes/c:visual_scene/c:node", COLLADA_NS):
        visit(node, top)
    return parts


def _geometry_parts(path, geometry, matrix, bindings, materials, prefix) -> list[MeshPart]:
    mesh = geometry.find("c:mesh", COLLADA_NS)
    if mesh is None:
        return []
    vertices_element = mesh.find("c:vertices", COLLADA_NS)
    position_id = vertices_element.find("c:input[@semantic='POSITION']", COLLADA_NS).get("source").lstrip("#")
    positions = _source_array(mesh, position_id, path)[:, :3]
    parts = []
    for index, primitive in enumerate(
        list(mesh.findall("c:triangles", COLLADA_NS)) + list(mesh.findall("c:polylist", COLLADA_NS))
    ):
        inputs = primitive.findall("c:input", COLLADA_NS)
        stride = 1 + max(int(i.get("offset", "0")) for i in inputs)
        indices = np.array((primitive.findtext("c:p", "", COLLADA_NS)).split(), dtype=np.int64).reshape(-1, stride)
        vcount_text = primitive.findtext("c:vcount", None, COLLADA_NS)
        if vcount_text is not None:  # polylist: fan-triangulate each polygon
            corners, start = [], 0
            for count in (int(v) for v in vcount_text.split()):
                corners += [j for k in range(1, count - 1) for j in (start, start + k, start + k + 1)]
                start += count
            indices = indices[np.array(corners, dtype=np.int64)]
        vertex_offset = next(int(i.get("offset")) for i in inputs if i.get("semantic") == "VERTEX")
        uv_input = next((i for i in inputs if i.get("semantic") == "TEXCOORD"), None)
        position_index = indices[:, vertex_offset]
        if uv_input is not None:
            uvs = _source_array(mesh, uv_input.get("source").lstrip("#"), path)[:, :2]
            uv_index = indices[:, int(uv_input.get("offset"))]
        else:
            uvs, uv_index = np.zeros((1, 2)), np.zeros_like(position_index)
        pairs, corner_to_vertex = np.unique(np.stack([position_index, uv_index], 1), axis=0, return_inverse=True)
        local = np.c_[positions[pairs[:, 0]], np.ones(len(pairs))]
        world = (matrix @ local.T).T[:, :3]
        texcoord = uvs[pairs[:, 1]].copy()
        texcoord[:, 1] = 1.0 - texcoord[:, 1]  # COLLADA's v runs up the image; MuJoCo's runs down
        faces = corner_to_vertex.reshape(-1, 3)
        if np.linalg.det(matrix[:3, :3]) < 0:
            faces = faces[:, [0, 2, 1]]
        texture, colour = materials.get(bindings.get(primitive.get("material"), ""), (None, (0.8, 0.8, 0.8)))
        name = f"{prefix}{geometry.get('id', 'mesh')}_{index}"
        parts.append(MeshPart(name, world, faces, texcoord, texture, tuple(colour)))
    return parts


def texture_png(path: Path) -> bytes:
    """A texture file (PNG or JPEG) as RGB PNG bytes, which MuJoCo reads."""
    try:
        image = Image.open(path).convert("RGB")
    except OSError as error:
        raise SimappWorldError(f"{path}: cannot read the texture: {error}") from error
    buffer = io.BytesIO()
    image.save(buffer, format="PNG")
    return buffer.getvalue()


def _xml_floats(values) -> str:
    return " ".join(f"{v:.6f}" for v in np.asarray(values, dtype=np.float64).ravel())


def simapp_scene_xml(world: SimappWorld, light_scale: float) -> tuple[str, str, str, dict[str, bytes]]:
    """MJCF fragments for the world's meshes: (asset elements, worldbody geoms, lights, texture files by name).

    The lights keep the world file's colours, directions and attenuation, times `light_scale` (MuJoCo units); the
    point light becomes a spot straight down with a 90 degree cut-off (MuJoCo's renderer draws no point light).
    """
    textures: dict[Path, str] = {}
    assets: dict[str, bytes] = {}
    asset_lines, geom_lines = [], []
    for index, part in enumerate(world.parts):
        if part.texture is not None and part.texture not in textures:
            name = f"simapp_tex_{len(textures)}"
            textures[part.texture] = name
            assets[f"{name}.png"] = texture_png(part.texture)
            asset_lines.append(f'    <texture name="{name}" type="2d" file="{name}.png"/>')
        material = f"simapp_mat_{index}"
        if part.texture is not None:
            asset_lines.append(
                f'    <material name="{material}" texture="{textures[part.texture]}" specular="0" shininess="0"/>'
            )
        else:
            asset_lines.append(
                f'    <material name="{material}" rgba="{_xml_floats(part.rgb)} 1" specular="0" shininess="0"/>'
            )
        # Lift each part by its order so coplanar layers (field, road, lines) do not z-fight; 0.1 mm per layer.
        vertices = part.vertices + np.array([0.0, 0.0, 1e-4 * index])
        asset_lines.append(
            f'    <mesh name="simapp_{index}" inertia="shell" vertex="{_xml_floats(vertices)}" '
            f'face="{" ".join(str(int(i)) for i in part.faces.ravel())}" texcoord="{_xml_floats(part.texcoord)}"/>'
        )
        geom_lines.append(
            f'    <geom name="simapp_{index}" type="mesh" mesh="simapp_{index}" material="{material}" '
            f'contype="0" conaffinity="0" group="1"/>'
        )
    ambient = light_scale * np.asarray(world.ambient)
    light_lines = []
    for index, light in enumerate(world.lights):
        diffuse = light_scale * np.asarray(light.diffuse)
        # The scene ambient rides on the first light (MuJoCo has no separate ambient term).
        light_ambient = ambient if index == 0 else np.zeros(3)
        common = f'diffuse="{_xml_floats(diffuse)}" ambient="{_xml_floats(light_ambient)}" specular="0 0 0" castshadow="false"'
        if light.directional:
            light_lines.append(
                f'    <light name="simapp_light_{index}" type="directional" pos="{_xml_floats(light.position_m)}" '
                f'dir="{_xml_floats(light.direction)}" {common}/>'
            )
        else:
            light_lines.append(
                f'    <light name="simapp_light_{index}" type="spot" cutoff="90" exponent="0" dir="0 0 -1" '
                f'pos="{_xml_floats(light.position_m)}" attenuation="{_xml_floats(light.attenuation)}" {common}/>'
            )
    return "\n".join(asset_lines), "\n".join(geom_lines), "\n".join(light_lines), assets
