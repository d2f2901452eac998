"""What the camera sees in each world: DeepRacer's re:Invent 2018 look, drawn from racer's own textures.

Facts taken from the SimApp's world files (`bundle/worlds/reinvent_*.world`, `models/reinvent_*/model.sdf`,
`meshes/reinvent/*.dae`; mesh units per file's `<unit>`, centimetre meshes scaled by their node matrix):

* base (`reinvent_base.dae`, metres): navy asphalt, 0.076 m off-white edge lines inside the road edge, an orange
  centre line dashed 0.0508 m on / 0.0508 m off and about 0.025 m wide, a mint-green field reaching 0.91 m past
  the road's bounding box, 1 m walls of flat dark teal around it, nothing above (no `<sky>`: a black background).
* carpet / concrete / wood (`walls.dae`, `field_*.dae`, centimetres): the whole floor, road included, is the
  carpet, concrete or wood texture; the same white edge and orange dashed lines; 2 m walls with a light-blue
  gradient 0.3 m past the road; a `<sky/>`.
* light, every world (SimApp v6.0.5): scene ambient 0.5; a directional sun along (-0.5, 0.1, -0.9) of colour
  (1, 1, 0.8); a point light 15 m above the origin, diffuse 0.225, attenuation (0.4, 0.01, 0). Materials are Phong
  with specular 0.5. Other generations light the same worlds differently (`Lighting`, `generations/looks.py`).

Colours are the ones the camera shows in DeepRacer's Gazebo frames (`frames/gazebo_reinvent_episode`: road
(36, 52, 68), edge lines (229, 230, 225), centre line (236, 143, 2), field (100, 143, 110), walls (37, 63, 76)
facing the light and (16, 26, 32) away from it); textures are divided by the light a floor receives so the
rendered floor shows those colours. The sun and point light keep the SimApp's directions and ratios, scaled by
`LIGHT_SCALE` (MuJoCo adds ambient and diffuse light without Ogre's tone mapping); a generation with other lights is
scaled so that the floor at the reference point gets the same light (`Lighting.scale`).

Anti-aliasing: the lines are painted into one mip-mapped road texture (margin | edge | asphalt | dash | asphalt |
edge | margin) instead of being separate meshes, so GL's texture filter smooths them the way DeepRacer's
640x480 + bilinear resize does, at the cost of a 160x120 frame. The road band reaches `ROAD_MARGIN_M` onto the field
with field colour, so its mesh edge is invisible; the walls carry the background colour above their top for the
same reason.
"""

from __future__ import annotations

import functools
import io
from dataclasses import dataclass

import numpy as np
from PIL import Image

RGB = tuple[int, int, int]

LIGHT_SCALE = 0.57
"""MuJoCo light per Gazebo light unit: with it, a floor under the SimApp's lights gets about 1.0x its texture."""
SUN_DIRECTION = (-0.5, 0.1, -0.9)
SUN_RGB = (1.0, 1.0, 0.8)
SCENE_AMBIENT = 0.5
POINT_LIGHT_POS_M = (0.0, 0.0, 15.0)
POINT_LIGHT_DIFFUSE = 0.225
POINT_LIGHT_ATTENUATION = (0.4, 0.01, 0.0)
ROAD_MARGIN_M = 0.12
"""How far the road band (and its field-coloured texture margin) reaches past the road edge."""
EDGE_LINE_WIDTH_M = 0.076
CENTER_LINE_WIDTH_M = 0.025
DASH_LENGTH_M = 0.0508
DASH_PERIOD_M = 0.1016
ROAD_TILE_DASHES = 8
"""Dash periods per road-texture tile along the road (one tile = 0.81 m)."""
ROAD_TEXTURE_PX = 512
"""Texels across the road band (about 2 mm each)."""
ROAD_TEXTURE_ALONG_PX = 128
"""Texels along one tile (6.35 mm each): coarser along the road, which the camera sees foreshortened, so GL's
mip-mapping blurs the lines less (see camera.TEXTURE_LOD_BIAS)."""
GRAIN_BLOB_PX = 4
"""Grain is drawn in blobs of this many texels across (and one along), about 8 x 6 mm: near-isotropic."""
FIELD_TEXTURE_PX = 256
FIELD_TILE_M = 1.0


@dataclass(frozen=True)
class WorldLook:
    """Colours (0-255, as rendered under the default light), grain and layout of one world."""

    name: str
    road_rgb: RGB
    field_rgb: RGB
    edge_line_rgb: RGB
    center_line_rgb: RGB
    wall_bottom_rgb: RGB
    wall_top_rgb: RGB
    background_rgb: RGB
    """Above the walls: black for base (no sky in its world file), a pale sky for the others."""
    road_grain: float
    """Standard deviation (grey levels) of the road's grain (and the field's, below)."""
    field_grain: float
    wall_height_m: float
    field_margin_m: float
    """Walls stand this far outside the road's bounding box."""


LOOKS: dict[str, WorldLook] = {
    "base": WorldLook(
        "base",
        road_rgb=(38, 55, 72),
        field_rgb=(100, 143, 110),
        edge_line_rgb=(242, 242, 236),
        center_line_rgb=(236, 143, 2),
        wall_bottom_rgb=(50, 90, 108),
        wall_top_rgb=(50, 90, 108),
        background_rgb=(0, 0, 0),
        road_grain=5.6,
        field_grain=6.4,
        wall_height_m=1.0,
        field_margin_m=0.91,
    ),
    "carpet": WorldLook(
        "carpet",
        road_rgb=(52, 52, 52),
        field_rgb=(52, 52, 52),
        edge_line_rgb=(229, 230, 225),
        center_line_rgb=(236, 143, 2),
        wall_bottom_rgb=(93, 159, 194),
        wall_top_rgb=(139, 186, 212),
        background_rgb=(178, 200, 222),
        road_grain=13.0,
        field_grain=13.0,
        wall_height_m=2.0,
        field_margin_m=0.3,
    ),
    "concrete": WorldLook(
        "concrete",
        road_rgb=(121, 116, 112),
        field_rgb=(121, 116, 112),
        edge_line_rgb=(229, 230, 225),
        center_line_rgb=(236, 143, 2),
        wall_bottom_rgb=(93, 159, 194),
        wall_top_rgb=(139, 186, 212),
        background_rgb=(178, 200, 222),
        road_grain=7.0,
        field_grain=7.0,
        wall_height_m=2.0,
        field_margin_m=0.3,
    ),
    "wood": WorldLook(
        "wood",
        road_rgb=(115, 74, 43),
        field_rgb=(115, 74, 43),
        edge_line_rgb=(229, 230, 225),
        center_line_rgb=(236, 143, 2),
        wall_bottom_rgb=(93, 159, 194),
        wall_top_rgb=(139, 186, 212),
        background_rgb=(178, 200, 222),
        road_grain=20.0,
        field_grain=20.0,
        wall_height_m=2.0,
        field_margin_m=0.3,
    ),
}


def get_look(world_name: str) -> WorldLook:
    try:
        return LOOKS[world_name]
    except KeyError:
        raise ValueError(f"no look for world {world_name!r}; looks exist for {', '.join(LOOKS)}") from None


@dataclass(frozen=True)
class LightSetting:
    """One light as MuJoCo gets it (already scaled): what domain randomisation changes per episode."""

    diffuse: tuple[float, float, float]
    attenuation: tuple[float, float, float]


FLOOR_REFERENCE_M = (4.0, 2.6)
"""Where on the floor the light is matched across lightings (a point of the re:Invent 2018 track, 15.7 m from the
point light)."""


@dataclass(frozen=True)
class Lighting:
    """One world file's lights in Gazebo units: scene ambient, a directional sun, a point light above the origin."""

    ambient: float
    sun_rgb: tuple[float, float, float]
    sun_direction: tuple[float, float, float]
    point_diffuse: float
    point_attenuation: tuple[float, float, float] = POINT_LIGHT_ATTENUATION
    point_pos_m: tuple[float, float, float] = POINT_LIGHT_POS_M
    gain: float = 1.0
    """Every light times this when drawn, the textures calibrated without it (a perturbation; 1 = the world's)."""

    def gazebo_floor_light(self, position_m: tuple[float, float] = FLOOR_REFERENCE_M) -> np.ndarray:
        """RGB light (Gazebo units) an up-facing surface receives at `position_m`."""
        sun = np.asarray(self.sun_direction, dtype=np.float64)
        cos_sun = max(0.0, -sun[2] / np.linalg.norm(sun))
        to_light = np.asarray(self.point_pos_m) - np.array([position_m[0], position_m[1], 0.0])
        distance = float(np.linalg.norm(to_light))
        constant, linear, quadratic = self.point_attenuation
        point = self.point_diffuse * (to_light[2] / distance) / (constant + linear * distance + quadratic * distance**2)
        return self.ambient + cos_sun * np.asarray(self.sun_rgb, dtype=np.float64) + point

    @property
    def scale(self) -> float:
        """MuJoCo light per Gazebo light unit: `LIGHT_SCALE` for the SimApp v6.0.5 lights; any other lighting is
        scaled so the floor at `FLOOR_REFERENCE_M` gets the same mean light, which keeps the calibrated floor
        colours and leaves what the lights change: their colour, direction and spread, and the walls' light.
        The textures are calibrated with it; the lights are drawn at `render_scale`."""
        reference = float(np.mean(SIMAPP6_LIGHTING.gazebo_floor_light()))
        return LIGHT_SCALE * reference / float(np.mean(self.gazebo_floor_light()))

    @property
    def render_scale(self) -> float:
        """The scale the lights are drawn with: `scale` times `gain`."""
        return self.scale * self.gain


SIMAPP6_LIGHTING = Lighting(SCENE_AMBIENT, SUN_RGB, SUN_DIRECTION, POINT_LIGHT_DIFFUSE)
"""deepracer-simapp v6.0.5 `bundle/worlds/reinvent_*.world`: the lights of today's worlds (and racer's default)."""


def default_lights(lighting: Lighting = SIMAPP6_LIGHTING) -> dict[str, LightSetting]:
    """A lighting's two lights, by racer light name, in MuJoCo units."""
    scale = lighting.render_scale
    return {
        "sun": LightSetting(tuple(scale * c for c in lighting.sun_rgb), (1.0, 0.0, 0.0)),
        "point": LightSetting((scale * lighting.point_diffuse,) * 3, lighting.point_attenuation),
    }


def floor_light(
    position_m: tuple[float, float] = FLOOR_REFERENCE_M, lighting: Lighting = SIMAPP6_LIGHTING
) -> np.ndarray:
    """RGB light factor an up-facing surface receives at `position_m` from a lighting's lights (MuJoCo units)."""
    return lighting.scale * lighting.gazebo_floor_light(position_m)


def _texture_rgb(rendered: RGB, lighting: Lighting = SIMAPP6_LIGHTING) -> np.ndarray:
    """Texture colour that renders as `rendered` on a floor under a lighting."""
    return np.asarray(rendered, dtype=np.float64) / floor_light(lighting=lighting)


PNG_COMPRESS_LEVEL = 1
"""zlib level of the in-memory texture PNGs MuJoCo decodes at every world build: lossless at any level, and level 1
encodes the grainy textures about 3x faster than PIL's default 6 for 5-15 % more bytes."""


def _png(pixels: np.ndarray) -> bytes:
    buffer = io.BytesIO()
    image = Image.fromarray(np.clip(np.rint(pixels), 0, 255).astype(np.uint8))
    image.save(buffer, format="PNG", compress_level=PNG_COMPRESS_LEVEL)
    return buffer.getvalue()


def _coverage(low: np.ndarray, high: np.ndarray, cell: float, edges: np.ndarray) -> np.ndarray:
    """Fraction of each texel [low, high) inside the union of sorted disjoint intervals `edges` (k, 2)."""
    covered = np.zeros_like(low)
    for start, stop in edges:
        covered += np.clip(np.minimum(high, stop) - np.maximum(low, start), 0.0, None)
    return covered / cell


def _grain(rng: np.random.Generator, std: float, rows: int, columns: int) -> np.ndarray:
    coarse = rng.normal(0.0, std, (rows, columns // GRAIN_BLOB_PX))
    return np.repeat(coarse, GRAIN_BLOB_PX, axis=1)[..., None]


@functools.cache
def road_texture_png(
    look: WorldLook, road_width_m: float, seed: int = 0, lighting: Lighting = SIMAPP6_LIGHTING
) -> bytes:
    """The road band's texture: u across the band (margin, lines, asphalt), v along `ROAD_TILE_DASHES` dashes.

    Texel colours are area-weighted where a line edge crosses a texel, so the texture itself is anti-aliased.
    """
    rng = np.random.default_rng(seed)
    size = ROAD_TEXTURE_PX
    along_px = ROAD_TEXTURE_ALONG_PX
    band_m = road_width_m + 2 * ROAD_MARGIN_M
    half_road = road_width_m / 2
    across_cell = band_m / size
    across_low = np.arange(size) * across_cell - band_m / 2
    across_high = across_low + across_cell
    road = _coverage(across_low, across_high, across_cell, np.array([[-half_road, half_road]]))
    edge = _coverage(
        across_low,
        across_high,
        across_cell,
        np.array([[-half_road, -half_road + EDGE_LINE_WIDTH_M], [half_road - EDGE_LINE_WIDTH_M, half_road]]),
    )
    centre_across = _coverage(
        across_low, across_high, across_cell, np.array([[-CENTER_LINE_WIDTH_M / 2, CENTER_LINE_WIDTH_M / 2]])
    )
    tile_m = ROAD_TILE_DASHES * DASH_PERIOD_M
    along_cell = tile_m / along_px
    along_low = np.arange(along_px) * along_cell
    dashes = np.array([[k * DASH_PERIOD_M, k * DASH_PERIOD_M + DASH_LENGTH_M] for k in range(ROAD_TILE_DASHES)])
    centre_along = _coverage(along_low, along_low + along_cell, along_cell, dashes)
    centre = centre_along[:, None] * centre_across[None, :]  # rows along the road, columns across
    field_w = (1.0 - road)[None, :, None]
    edge_w = edge[None, :, None]
    asphalt_w = np.clip(road[None, :] - edge[None, :] - centre, 0.0, None)[..., None]
    road_noise = _grain(rng, look.road_grain, along_px, size)
    field_noise = _grain(rng, look.field_grain, along_px, size)
    pixels = (
        field_w * (_texture_rgb(look.field_rgb, lighting) + field_noise)
        + asphalt_w * (_texture_rgb(look.road_rgb, lighting) + road_noise)
        + edge_w * _texture_rgb(look.edge_line_rgb, lighting)
        + centre[..., None] * _texture_rgb(look.center_line_rgb, lighting)
    )
    return _png(pixels)


def road_tile_length_m() -> float:
    return ROAD_TILE_DASHES * DASH_PERIOD_M


@functools.cache
def field_texture_png(look: WorldLook, seed: int = 1, lighting: Lighting = SIMAPP6_LIGHTING) -> bytes:
    rng = np.random.default_rng(seed)
    size = FIELD_TEXTURE_PX
    return _png(_texture_rgb(look.field_rgb, lighting) + rng.normal(0.0, look.field_grain, (size, size, 1)))


WALL_TEXTURE_PX = 64
WALL_EXTENSION_M = 6.0
"""The wall meshes go this far above the wall top, painted in the background colour (cheaper than a skybox)."""


@functools.cache
def wall_texture_png(look: WorldLook) -> bytes:
    """A vertical strip: the wall's gradient from its foot (texture bottom) to its top, background above."""
    total_m = look.wall_height_m + WALL_EXTENSION_M
    heights = (np.arange(WALL_TEXTURE_PX)[::-1] + 0.5) / WALL_TEXTURE_PX * total_m  # row 0 is the top
    fraction = np.clip(heights / look.wall_height_m, 0.0, 1.0)[:, None]
    wall = (1 - fraction) * np.asarray(look.wall_bottom_rgb, float) + fraction * np.asarray(look.wall_top_rgb, float)
    cell = total_m / WALL_TEXTURE_PX
    inside = np.clip((look.wall_height_m - (heights - cell / 2)) / cell, 0.0, 1.0)[:, None]
    colour = inside * wall + (1 - inside) * np.asarray(look.background_rgb, float)
    return _png(np.repeat(colour[:, None, :], 4, axis=1))
