"""Writes `tracks/track_looks.json`: each SimApp track world's road, line, field and wall colours.

    .venv/bin/python tools/track_looks_from_simapp.py GIT_DIR [--tag v5.3.3 --tag v6.0.5] [--out PATH]

GIT_DIR is a git directory of aws-deepracer-community/deepracer-simapp (read with `git show TAG:PATH`, no work tree
needed). For every `bundle/worlds/<WORLD_NAME>.world` (the first tag that has it wins; the four re:Invent 2018 worlds
and `reinvent_base_jeremiah` are left to `world_look.py`) it follows the world's `model://models/<name>` includes to
their `*.sdf`, takes each `<visual>`'s COLLADA mesh and reads its `<effect>`s: a `<diffuse><color>` is taken as is; a
diffuse `<texture>` is followed through the effect's sampler/surface params and `<library_images>` to its file, and
the file's mean RGB (all texels, 0-1) is the colour. SDF `<material>` ambient/diffuse colours are used where a
visual has no mesh colour. Each effect gets a role from its effect id and texture file name (road, edge line,
centre line, field, wall, backdrop); parts of the scenery (buildings, signs, trees, finish lines, ...) are skipped.
For meshes made by DeepRacer's trackgen (geometries `roadmesh0`, `olmesh0`, `clmesh0`, `fieldmesh0`, `wallmesh0`)
it also measures the edge-line width, the centre line's width and dash length, the field's margin past the road
and the wall height from the vertices. Only numbers and file names go into the table; no texture is copied.
"""

from __future__ import annotations

import argparse
import io
import json
import re
import subprocess
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from PIL import Image

REPOSITORY = "aws-deepracer-community/deepracer-simapp"
ROLES = ("road", "edge_line", "center_line", "field", "wall", "backdrop")
C = "{http://www.collada.org/2005/11/COLLADASchema}"
REINVENT_2018 = ("reinvent_base", "reinvent_carpet", "reinvent_concrete", "reinvent_wood", "reinvent_base_jeremiah")
SCENERY = (
    "building", "landmark", "city", "sideroad", "sign", "billboard", "tree", "cloud", "light", "finishline",
    "startline", "stands", "palace", "hotel", "docks", "river", "tunnel", "logo", "camera", "water", "gate",
    "tower", "stars", "enviro", "dirt", "_ground_", "collision",
)  # fmt: skip
EFFECT_SCENERY = (
    "building", "landmark", "billboard", "tree", "cloud", "logo", "startline", "finish", "water", "sea_", "river",
    "sign_", "_sign", "glass", "concrete", "stars", "gravel", "pit_", "wood",
)  # fmt: skip
"""Effects skipped wherever they are (a field mesh also holds a concrete border, a road mesh a finish line)."""
ROLE_PATTERNS = (  # first match wins; matched against "effect id|texture file|mesh file", lower case
    ("center_line", ("centerline", "center_line", "center_yellow", "cleffect", "cl_material", "yellow")),
    ("edge_line", ("outerline", "outer_line", "edge_white", "borderline", "oleffect", "ileffect", "ol_material",
                   "il_material", "outline", "m_white", "lambert1_00")),
    ("wall", ("walleffect", "wall_material", "track_barrier", "mi_barrier", "track_metal")),
    ("backdrop", ("grandstands", "background", "terrain_wall", "terrain-wall")),
    ("kerb", ("barrier", "side_edge", "side-ege", "side_edging")),
    ("road", ("road", "m_road", "track-road", "mi_track-fx")),
    ("field", ("field", "grass")),
)  # fmt: skip


def git(git_dir: str, *args: str) -> bytes:
    return subprocess.run(["git", "--git-dir", git_dir, *args], capture_output=True, check=False).stdout


@dataclass
class Part:
    role: str
    rgb: tuple[float, float, float]
    source: str


@dataclass
class WorldFacts:
    world: str
    tag: str
    world_file: str
    sky: bool
    parts: list[Part] = field(default_factory=list)
    geometry: dict[str, float] = field(default_factory=dict)
    geometry_source: str = ""


class Reader:
    def __init__(self, git_dir: str, tag: str) -> None:
        self.git_dir, self.tag = git_dir, tag
        self.files = set(git(git_dir, "ls-tree", "-r", "--name-only", tag, "bundle").decode().splitlines())
        self._means: dict[str, tuple[float, float, float] | None] = {}

    def show(self, path: str) -> bytes:
        return git(self.git_dir, "show", f"{self.tag}:{path}") if path in self.files else b""

    def image_mean(self, path: str) -> tuple[float, float, float] | None:
        """Mean RGB (0-1) of an image file; None when it is missing, a pointer file or unreadable."""
        if path not in self._means:
            try:
                image = Image.open(io.BytesIO(self.show(path))).convert("RGB")
                pixels = np.asarray(image, dtype=np.float64) / 255.0
                self._means[path] = tuple(round(float(v), 4) for v in pixels.reshape(-1, 3).mean(axis=0))  # type: ignore[assignment]
            except (OSError, ValueError):  # PIL's UnidentifiedImageError is an OSError; a git-lfs pointer is one
                self._means[path] = None
        return self._means[path]


def _role(text: str) -> str | None:
    text = text.lower()
    for role, patterns in ROLE_PATTERNS:
        if any(p in text for p in patterns):
            return role
    return None


def _effect_colours(reader: Reader, path: str, root: ET.Element) -> list[tuple[str, str, tuple[float, ...]]]:
    """(effect id, texture file or '', rgb 0-1) per effect with a diffuse colour or a readable texture."""
    images = {}
    for image in root.iter(f"{C}image"):
        init = image.find(f".//{C}init_from")
        if init is not None and init.text:
            images[image.get("id")] = init.text.strip()
    out = []
    for effect in root.iter(f"{C}effect"):
        params = {}
        for param in effect.iter(f"{C}newparam"):
            init, source = param.find(f".//{C}init_from"), param.find(f".//{C}source")
            params[param.get("sid")] = (
                init.text.strip() if init is not None and init.text else None,
                source.text.strip() if source is not None and source.text else None,
            )
        diffuse = effect.find(f".//{C}diffuse")
        if diffuse is None:
            continue
        colour, texture = diffuse.find(f"{C}color"), diffuse.find(f"{C}texture")
        if colour is not None and colour.text:
            rgb = tuple(round(float(v), 4) for v in colour.text.split()[:3])
            out.append((effect.get("id") or "", "", rgb))
        elif texture is not None:
            name = texture.get("texture") or ""
            if name in params and params[name][1] in params:  # sampler -> surface -> image id
                name = params[params[name][1]][0] or name
            file_name = images.get(name, name)
            image_path = str(Path(path).parent / file_name.replace("%20", " "))
            mean = reader.image_mean(image_path)
            if mean is not None:
                out.append((effect.get("id") or "", file_name, mean))
    return out


def _trackgen_geometry(root: ET.Element, unit_m: float) -> dict[str, float]:
    """Line widths, dash length, field margin and wall height of a trackgen mesh (empty if it is not one)."""

    def verts(geometry_id: str) -> np.ndarray | None:
        geometry = root.find(f".//{C}geometry[@id='{geometry_id}']")
        if geometry is None:
            return None
        array = geometry.find(f".//{C}float_array")
        return np.array(array.text.split(), dtype=np.float64).reshape(-1, 3) * unit_m

    road, ol, cl, fld, wall = (verts(g) for g in ("roadmesh0", "olmesh0", "clmesh0", "fieldmesh0", "wallmesh0"))
    if road is None or ol is None or cl is None:
        return {}
    facts = {
        "edge_line_width_m": float(np.median(np.linalg.norm(ol[0::2, :2] - ol[1::2, :2], axis=1))),
        # Dashes are quads (4 vertices): 0-1 across one end, 0-2 along the dash.
        "center_line_width_m": float(np.median(np.linalg.norm(cl[0::4, :2] - cl[1::4, :2], axis=1))),
        "dash_length_m": float(np.median(np.linalg.norm(cl[0::4, :2] - cl[2::4, :2], axis=1))),
    }
    if len(cl) >= 8:
        facts["dash_period_m"] = float(np.median(np.linalg.norm(cl[4::4, :2] - cl[0:-4:4, :2], axis=1)))
    if fld is not None:
        facts["field_margin_m"] = float(
            np.min(np.concatenate([road[:, :2].min(0) - fld[:, :2].min(0), fld[:, :2].max(0) - road[:, :2].max(0)]))
        )
    if wall is not None:
        facts["wall_height_m"] = float(np.ptp(wall[:, 2]))
    return {k: round(v, 4) for k, v in facts.items()}


def world_facts(reader: Reader, world: str) -> WorldFacts:
    world_file = f"bundle/worlds/{world}.world"
    text = reader.show(world_file).decode("utf-8", "replace")
    facts = WorldFacts(world, reader.tag, world_file, sky=bool(re.search(r"<sky\b", text)))
    for model in re.findall(r"model://models/([^<\s]+)", text):
        for sdf in sorted(f for f in reader.files if f.startswith(f"bundle/models/{model}/") and f.endswith(".sdf")):
            sdf_text = reader.show(sdf).decode("utf-8", "replace")
            for visual in re.findall(r"<visual\b.*?</visual>", sdf_text, re.S):
                meshes = re.findall(r"model://(meshes/[^<\s]+)", visual)
                for mesh in meshes:
                    _mesh_parts(reader, f"bundle/{mesh}", facts)
                material = re.search(r"<material>.*?<diffuse>([^<]+)</diffuse>", visual, re.S)
                role = _role(" ".join(meshes) + visual[:200])
                if material and role and not any(p.role == role for p in facts.parts):
                    rgb = tuple(round(float(v), 4) for v in material.group(1).split()[:3])
                    facts.parts.append(Part(role, rgb, f"{sdf} <material><diffuse>"))  # type: ignore[arg-type]
    return facts


def _mesh_parts(reader: Reader, path: str, facts: WorldFacts) -> None:
    mesh_name = Path(path).name.lower()
    if mesh_name == "ground.dae" or (any(word in mesh_name for word in SCENERY) and "track_road" not in mesh_name):
        return
    data = reader.show(path)
    if not data:
        return
    try:
        root = ET.fromstring(data)
    except ET.ParseError:
        return
    unit = root.find(f"{C}asset/{C}unit")
    unit_m = float(unit.get("meter", "1")) if unit is not None else 1.0
    effects = [
        e for e in _effect_colours(reader, path, root) if not any(w in f"{e[0]}|{e[1]}".lower() for w in EFFECT_SCENERY)
    ]
    # An effect's own id and texture name say its role; the mesh's name only for effects that say nothing.
    for by_mesh_name in (False, True):
        for effect_id, texture, rgb in effects:
            role = _role(f"{effect_id}|{texture}")
            if by_mesh_name:
                role = role or _role(mesh_name)
            if role is None or role == "kerb" or any(p.role == role for p in facts.parts):
                continue
            where = f"{path} effect {effect_id}" + (f" texture {texture} (mean)" if texture else " diffuse colour")
            facts.parts.append(Part(role, rgb, where))  # type: ignore[arg-type]
    if not facts.geometry:
        geometry = _trackgen_geometry(root, unit_m)
        if geometry:
            facts.geometry, facts.geometry_source = geometry, f"{path} (trackgen vertices)"


def table_document(all_facts: list[WorldFacts], tags: list[str]) -> dict:
    """The JSON document `shared/sim/scene/track_looks.py` reads: an `about` line and one entry per world with a road."""
    worlds = {}
    for f in all_facts:
        parts = {p.role: p for p in f.parts}
        if "road" not in parts:
            continue
        entry: dict = {"tag": f.tag, "world_file": f.world_file, "sky": f.sky}
        entry.update({role: list(parts[role].rgb) for role in ROLES if role in parts})
        entry["sources"] = {role: parts[role].source for role in ROLES if role in parts}
        if f.geometry:
            entry["geometry"] = dict(f.geometry)
            entry["geometry_source"] = f.geometry_source
        worlds[f.world] = entry
    about = (
        f"Generated by `python tools/track_looks_from_simapp.py SIMAPP_GIT_DIR` from {REPOSITORY}, tags "
        f"{', '.join(tags)} (do not edit by hand: re-run it). Colours are 0-1 RGB as the files state them: an "
        "effect's diffuse colour or the mean of its diffuse texture; `sources` names the file, effect and texture of "
        "each part; `geometry` is measured from trackgen vertices where the mesh is one. Read by "
        "shared/sim/scene/track_looks.py."
    )
    return {"about": about, "worlds": worlds}


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("git_dir")
    parser.add_argument("--tag", action="append", default=None, help="tags in order of preference")
    parser.add_argument("--out", type=Path, default=Path(__file__).resolve().parents[1] / "tracks" / "track_looks.json")
    args = parser.parse_args(argv)
    tags = args.tag or ["v5.3.3", "v6.0.5"]
    seen: set[str] = set()
    all_facts = []
    for tag in tags:
        reader = Reader(args.git_dir, tag)
        for path in sorted(reader.files):
            match = re.fullmatch(r"bundle/worlds/(.+)\.world", path)
            if match and match.group(1) not in seen and match.group(1) not in REINVENT_2018:
                seen.add(match.group(1))
                all_facts.append(world_facts(reader, match.group(1)))
    all_facts.sort(key=lambda f: f.world)
    args.out.write_text(json.dumps(table_document(all_facts, tags), indent=1) + "\n")
    with_road = sum(1 for f in all_facts if any(p.role == "road" for p in f.parts))
    print(f"{args.out}: {with_road} of {len(all_facts)} worlds")


if __name__ == "__main__":
    main()
