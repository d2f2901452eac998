"""What the camera sees in each DeepRacer generation: the worlds' lights, the re:Invent 2018 base world's walls, the
camera mount. MuJoCo-free (the config names them). `generations.py` pairs each look with its car.

Facts per generation, each from that generation's own files (no code copied; docs/deepracer-sources.md):

* `2019`: aws-deepracer-community/deepracer-core at 6d9f8481 (2019-12-04), under
  `simulation/aws-robomaker-sample-application-deepracer/simulation_ws/src/deepracer_simulation/`:
  `worlds/reinvent_{base,carpet,concrete,wood}.world` include Gazebo's `model://sun` (osrf/gazebo_models at
  12e83edd, `sun/model.sdf`: diffuse 0.8 grey along (-0.5, 0.5, -1.0)) and a point light of diffuse 0.9 at 15 m,
  attenuation (0.4, 0.01, 0), scene ambient 0.5, no `<sky>`. `models/reinvent_base/model.sdf` draws the base world
  from `meshes/reinvent/walls.dae`, `field.dae`, `road.dae` and the line meshes: the walls are the ones today's
  carpet, concrete and wood worlds still use (`walls.dae`, byte-identical to the SimApp's: 2 m high, about 0.3 m
  past the route's bounding box, `textures/walls.jpg`, a light-blue gradient, whose rows racer's carpet look already
  carries). The field, road and lines are the same meshes as today's.
* `simapp5`: deepracer-simapp tag v5.3.3, `bundle/worlds/reinvent_base.world`: `model://sun` as above, a point
  light of diffuse 0.225; `models/reinvent_base/model.sdf` draws `reinvent_base.dae` (1 m walls 0.91 m out).
* `simapp6`: deepracer-simapp tag v6.0.5, the same world with an explicit sun of colour (1, 1, 0.8) along
  (-0.5, 0.1, -0.9) and the point light of 0.225 (`world_look.SIMAPP6_LIGHTING`): racer's default look.

The camera: every generation mounts it at (0.14529, 0, 0.13033) m pitched 15 degrees for models of SimApp version 3
and later (deepracer-simapp v5.3.3 `bundle/markov/cameras/frustum.py`; `car.CAMERA_POS_M`), and racer's
`car.LEGACY_CAMERA_POS_M` for older models. deepracer-core 6d9f8481's `urdf/racecar.xacro` puts the camera at
(0.20, 0, 0.134) m on a chassis 0.03 m above `base_link`, which sits on the ground under the rear axle of a
0.195 m-wheelbase car with 0.03 m wheels: 0.164 m up, exactly the legacy mount, and that repository's agent writes
model version 1.0 (`markov/utils.py` SIMAPP_VERSION, wheel radius 0.1 m). The shared 2019 checkpoints are version 3
models, and the 92 Gazebo frames fit the version-3 mount (median line error 1.84 cm) better than the legacy one
(3.23 cm; research/frame_pairs/): so the frames and the checkpoints come from the version-3 car, and `2019` keeps its
mount. The floors' colours are the ones calibrated on those 2019 frames in every generation (no later frames exist).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from racer.shared.sim.scene import track_looks, world_look
from racer.shared.sim.scene.world_look import SIMAPP6_LIGHTING, Lighting, WorldLook

GAZEBO_MODEL_SUN_RGB = (0.8, 0.8, 0.8)
GAZEBO_MODEL_SUN_DIRECTION = (-0.5, 0.5, -1.0)
"""Gazebo classic's `model://sun` (osrf/gazebo_models 12e83edd `sun/model.sdf`), which the ROS 1 worlds include."""
SIMAPP5_LIGHTING = Lighting(0.5, GAZEBO_MODEL_SUN_RGB, GAZEBO_MODEL_SUN_DIRECTION, 0.225)
LIGHTING_2019 = Lighting(0.5, GAZEBO_MODEL_SUN_RGB, GAZEBO_MODEL_SUN_DIRECTION, 0.9)

WALLS_2019_HEIGHT_M = 2.0
WALLS_2019_MARGIN_M = 0.3
"""deepracer-core 6d9f8481 `meshes/reinvent/walls.dae` around the re:Invent 2018 route (as racer's carpet look)."""


@dataclass(frozen=True)
class GenerationLook:
    """A generation's lights, base-world walls and camera mount; `world_look` adapts racer's look of a world to it."""

    name: str
    lighting: Lighting
    base_walls_from_carpet: bool
    """True: the base world has the 2 m `walls.dae` walls 0.3 m out (2019); False: today's 1 m walls 0.91 m out."""
    sky: bool
    """False: nothing above the walls in any world (the 2019 worlds have no `<sky>`); True: as racer's looks say."""
    camera_pos_m: tuple[float, float, float] | None = None
    """None: the mount of the model's SimApp version (`car.camera_mount_m`, the same in every generation); set only
    to move the camera (the robustness bench)."""
    camera_pitch_down_rad: float | None = None
    """None: `car.CAMERA_PITCH_DOWN_RAD` (15 degrees, every generation)."""

    def world_look(self, track_name: str, world_name: str) -> WorldLook:
        """racer's look of this route in this world (`track_looks.look_for`), with this generation's walls and sky."""
        look = track_looks.look_for(track_name, world_name)
        if look is not world_look.LOOKS.get(world_name):
            return look  # a track with its own SimApp look: drawn from the later SimApp's files in every generation
        if self.base_walls_from_carpet and world_name == "base":
            carpet = world_look.LOOKS["carpet"]
            look = dataclasses.replace(
                look,
                name="base:2019",
                wall_bottom_rgb=carpet.wall_bottom_rgb,
                wall_top_rgb=carpet.wall_top_rgb,
                wall_height_m=WALLS_2019_HEIGHT_M,
                field_margin_m=WALLS_2019_MARGIN_M,
            )
        if not self.sky and look.background_rgb != (0, 0, 0):
            look = dataclasses.replace(look, name=f"{look.name}:no-sky", background_rgb=(0, 0, 0))
        return look

    def with_light_factor(self, factor: float) -> GenerationLook:
        """The same look with every light (ambient, sun, point) times `factor`, the textures as they are: a
        perturbation for the robustness bench (the floor renders `factor` times as bright)."""
        lighting = dataclasses.replace(self.lighting, gain=self.lighting.gain * factor)
        return dataclasses.replace(self, name=f"{self.name}:light x{factor:g}", lighting=lighting)


LOOK_2019 = GenerationLook("2019", LIGHTING_2019, base_walls_from_carpet=True, sky=False)
LOOK_SIMAPP5 = GenerationLook("simapp5", SIMAPP5_LIGHTING, base_walls_from_carpet=False, sky=True)
LOOK_SIMAPP6 = GenerationLook("simapp6", SIMAPP6_LIGHTING, base_walls_from_carpet=False, sky=True)
