"""The four worlds a route can be driven in: same geometry, different grip and look.

DeepRacer ships re:Invent 2018 as `reinvent_base`, `reinvent_carpet`, `reinvent_concrete` and `reinvent_wood`:
one route, different surfaces. Training on several makes a policy less sensitive to the look of the floor.
What each world looks like (colours, textures, walls, light) is in `world_look.py` (and, for a track whose SimApp
world has its own colours, `track_looks.py`: in `base` it gets them); the tyre friction below is
this project's choice (DeepRacer's tyre μ is 0.5 on every surface: deepracer-simapp v5.3.3
`bundle/urdf/deepracer/racecar.gazebo`).
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class World:
    name: str
    tyre_friction: float
    """Sliding friction coefficient between tyres and floor (MuJoCo takes the larger geom value; both get it)."""


WORLDS: dict[str, World] = {
    "base": World(name="base", tyre_friction=0.5),
    "carpet": World(name="carpet", tyre_friction=0.65),
    "concrete": World(name="concrete", tyre_friction=0.55),
    "wood": World(name="wood", tyre_friction=0.42),
}

WORLD_NAMES: tuple[str, ...] = tuple(WORLDS)


def get_world(name: str) -> World:
    """The world preset of that name; a clear error lists the valid names."""
    try:
        return WORLDS[name]
    except KeyError:
        raise ValueError(f"unknown world {name!r}; choose one of {', '.join(WORLD_NAMES)}") from None
