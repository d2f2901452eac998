"""The four worlds a route can be driven in: same geometry, different grip, textures and light.

DeepRacer ships re:Invent 2018 as `reinvent_base`, `reinvent_carpet`, `reinvent_concrete` and `reinvent_wood`:
one route, different surfaces. Training on several makes a policy less sensitive to the look of the floor.
The numbers below are this project's choices (DeepRacer's tyre μ is 0.5 on every surface, reference §9.1);
they are kept in one table so a world is a name, not code.
"""

from __future__ import annotations

from dataclasses import dataclass

RGB = tuple[float, float, float]


@dataclass(frozen=True)
class Texture:
    """A MuJoCo builtin procedural texture (`checker` / `gradient` / `flat`, optional random speckle)."""

    builtin: str
    rgb1: RGB
    rgb2: RGB
    mark: str = "none"
    markrgb: RGB = (0.0, 0.0, 0.0)
    random: float = 0.0
    size_px: int = 256
    repeat_per_m: float = 1.0
    """How many texture tiles cover one metre of floor or road."""


@dataclass(frozen=True)
class Lighting:
    direction: tuple[float, float, float]
    diffuse: RGB
    ambient: RGB
    headlight_diffuse: RGB
    headlight_ambient: RGB


@dataclass(frozen=True)
class World:
    name: str
    tyre_friction: float
    """Sliding friction coefficient between tyres and floor (MuJoCo takes the larger geom value; both get it)."""
    ground: Texture
    road: Texture
    border_rgb: RGB
    center_line_rgb: RGB
    lighting: Lighting
    skybox_rgb: tuple[RGB, RGB]


WORLDS: dict[str, World] = {
    "base": World(
        name="base",
        tyre_friction=0.5,
        ground=Texture("checker", (0.36, 0.42, 0.34), (0.33, 0.39, 0.31), mark="random", markrgb=(0.45, 0.5, 0.4), random=0.02, repeat_per_m=0.5),
        road=Texture("flat", (0.13, 0.13, 0.14), (0.13, 0.13, 0.14), mark="random", markrgb=(0.3, 0.3, 0.3), random=0.04, repeat_per_m=1.0),
        border_rgb=(0.95, 0.95, 0.95),
        center_line_rgb=(0.95, 0.75, 0.1),
        lighting=Lighting((0.3, 0.2, -1.0), (0.7, 0.7, 0.7), (0.3, 0.3, 0.3), (0.2, 0.2, 0.2), (0.1, 0.1, 0.1)),
        skybox_rgb=((0.55, 0.65, 0.8), (0.9, 0.9, 0.95)),
    ),
    "carpet": World(
        name="carpet",
        tyre_friction=0.65,
        ground=Texture("checker", (0.18, 0.22, 0.45), (0.22, 0.26, 0.5), mark="random", markrgb=(0.35, 0.35, 0.6), random=0.15, repeat_per_m=4.0),
        road=Texture("checker", (0.2, 0.2, 0.22), (0.24, 0.24, 0.26), mark="random", markrgb=(0.4, 0.4, 0.45), random=0.12, repeat_per_m=3.0),
        border_rgb=(0.9, 0.9, 0.85),
        center_line_rgb=(0.9, 0.85, 0.2),
        lighting=Lighting((-0.4, 0.3, -1.0), (0.55, 0.55, 0.5), (0.35, 0.35, 0.33), (0.25, 0.25, 0.25), (0.1, 0.1, 0.1)),
        skybox_rgb=((0.4, 0.4, 0.45), (0.7, 0.7, 0.72)),
    ),
    "concrete": World(
        name="concrete",
        tyre_friction=0.55,
        ground=Texture("flat", (0.62, 0.61, 0.58), (0.62, 0.61, 0.58), mark="random", markrgb=(0.45, 0.45, 0.43), random=0.08, repeat_per_m=1.0),
        road=Texture("flat", (0.3, 0.3, 0.31), (0.3, 0.3, 0.31), mark="random", markrgb=(0.5, 0.5, 0.5), random=0.1, repeat_per_m=1.5),
        border_rgb=(1.0, 1.0, 1.0),
        center_line_rgb=(1.0, 0.8, 0.0),
        lighting=Lighting((0.1, -0.5, -1.0), (0.85, 0.85, 0.85), (0.35, 0.35, 0.35), (0.2, 0.2, 0.2), (0.15, 0.15, 0.15)),
        skybox_rgb=((0.7, 0.75, 0.85), (0.95, 0.95, 0.97)),
    ),
    "wood": World(
        name="wood",
        tyre_friction=0.42,
        ground=Texture("gradient", (0.55, 0.36, 0.2), (0.42, 0.26, 0.13), mark="random", markrgb=(0.35, 0.2, 0.1), random=0.05, repeat_per_m=2.0),
        road=Texture("flat", (0.16, 0.12, 0.1), (0.16, 0.12, 0.1), mark="random", markrgb=(0.3, 0.22, 0.16), random=0.05, repeat_per_m=1.0),
        border_rgb=(0.93, 0.9, 0.82),
        center_line_rgb=(0.95, 0.7, 0.15),
        lighting=Lighting((0.5, 0.5, -1.0), (0.75, 0.65, 0.5), (0.3, 0.26, 0.2), (0.25, 0.22, 0.18), (0.12, 0.1, 0.08)),
        skybox_rgb=((0.6, 0.5, 0.4), (0.85, 0.8, 0.75)),
    ),
}

WORLD_NAMES: tuple[str, ...] = tuple(WORLDS)


def get_world(name: str) -> World:
    """The world preset of that name; a clear error lists the valid names."""
    try:
        return WORLDS[name]
    except KeyError:
        raise ValueError(f"unknown world {name!r}; choose one of {', '.join(WORLD_NAMES)}") from None
