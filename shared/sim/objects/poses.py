"""What stands on the track besides the agent: static obstacles and bot cars, as one pose list per step.

The track-object logic (placement, bot motion, collisions, reward params) produces `ObjectPose`s; the scene, the sensors,
the recording and the analysis only read them. Sizes are the SimApp's collision rectangles
(deepracer-simapp v5.3.3 `bundle/markov/track_geom/track_data.py`: box_obstacle 0.4 x 0.5 m, a DeepRacer car 0.1961 x
0.32352 m).
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum


class ObjectKind(Enum):
    BOX_OBSTACLE = "box_obstacle"
    """A static obstacle (OBSTACLE_TYPE box_obstacle, or any static type drawn as a box)."""
    BOT_CAR = "bot_car"
    """A DeepRacer car driving its lane (HEAD_TO_BOT bots, or IS_OBSTACLE_BOT_CAR static cars)."""


@dataclass(frozen=True)
class ObjectSize:
    width_m: float
    """Across the object's heading."""
    length_m: float
    """Along the object's heading."""
    height_m: float
    """As drawn (the SimApp's box model is 0.25 m high, a DeepRacer shell about 0.2 m); the crash test is 2-D."""


BOX_OBSTACLE_SIZE = ObjectSize(width_m=0.4, length_m=0.5, height_m=0.25)
BOT_CAR_SIZE = ObjectSize(width_m=0.1961, length_m=0.32352, height_m=0.205)

SIZES: dict[ObjectKind, ObjectSize] = {ObjectKind.BOX_OBSTACLE: BOX_OBSTACLE_SIZE, ObjectKind.BOT_CAR: BOT_CAR_SIZE}


@dataclass(frozen=True)
class ObjectPose:
    """One object's pose at one instant, in the track's world frame (the frame of the route's waypoints)."""

    name: str
    """Stable for the whole run ("obstacle_0", "bot_car_1"): sensors and recordings key on it."""
    kind: ObjectKind
    x_m: float
    y_m: float
    yaw_rad: float
    """Heading, counter-clockwise from +x."""
    speed_mps: float = 0.0

    @property
    def size(self) -> ObjectSize:
        return SIZES[self.kind]
