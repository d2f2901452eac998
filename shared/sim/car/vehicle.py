"""The DeepRacer car in MuJoCo: its geometry (deepracer-simapp v5.3.3
`bundle/urdf/deepracer/deepracer_single_cam.urdf`), its MJCF, and reading/commanding it.

Frame: the car origin (DeepRacer's `base_link`) sits on the ground between the axles, x forward, y left, z up.
All four wheels get the same angular velocity `speed / 0.035` and both steering hinges the same angle
(no Ackermann), as DeepRacer's `send_action`. Commands are clipped to 0.1–4 m/s and ±30° before being sent;
the zero command of the `prepare` step is sent unclipped. The wheels touch the floor without friction; the
horizontal tyre forces come from `tyres.py`, so the car is stepped with `Car.step`, not `mujoco.mj_step` alone.
The dynamics constants (tyres, steering servo, yaw inertia) come as one `car.dynamics.CarDynamics`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from racer.shared.sim.car.dynamics import (  # noqa: F401  (re-exported: the fit and its tests read them here)
    GAZEBO_DYNAMICS,
    STEERING_TIME_CONSTANT_S,
    YAW_INERTIA_KGM2,
    CarDynamics,
)
from racer.shared.sim.car.tyres import TyreParams, Tyres
from racer.shared.sim.scene._mujoco import mujoco

WHEEL_RADIUS_M = 0.035
"""The simulated tyre's radius."""
COMMAND_WHEEL_RADIUS_M = 0.035
"""The radius the SimApp divides the speed by to get wheel rad/s (models of version >= 3)."""
REAR_AXLE_X_M = -0.081663
FRONT_AXLE_X_M = 0.082311
REAR_HALF_TRACK_M = 0.08105
FRONT_HALF_TRACK_M = 0.079601
WHEELBASE_M = FRONT_AXLE_X_M - REAR_AXLE_X_M
WHEEL_MASS_KG = 0.34055
HINGE_MASS_KG = 0.1
URDF_CHASSIS_MASS_KG = 5.0
TOTAL_MASS_KG = URDF_CHASSIS_MASS_KG + 4 * WHEEL_MASS_KG + 2 * HINGE_MASS_KG
"""6.5622 kg, the SimApp URDF's chassis, wheels and hinges."""
CHASSIS_MASS_KG = TOTAL_MASS_KG - 4 * WHEEL_MASS_KG - 2 * HINGE_MASS_KG
STEERING_LIMIT_RAD = 1.0
"""Joint limit of the steering hinges (URDF)."""

MIN_SPEED_MPS = 0.1
MAX_SPEED_MPS = 4.0
MAX_STEERING_DEG = 30.0

CAMERA_POS_M = (0.14529, 0.0, 0.13033)
LEGACY_CAMERA_POS_M = (0.2, 0.0, 0.164)
"""Camera mount of SimApp models older than version 3 (deepracer-simapp v5.3.3 `bundle/markov/cameras/frustum.py`)."""
CAMERA_PITCH_DOWN_RAD = 0.2618
CAMERA_HORIZONTAL_FOV_RAD = 1.13
CAMERA_ASPECT = 4.0 / 3.0
STEREO_HALF_BASELINE_M = 0.03
LIDAR_POS_M = (0.02, 0.0, 0.16)
"""[chosen] The LIDAR sits on top of the car, above the camera mount."""

WHEEL_NAMES = ("left_rear_wheel", "left_front_wheel", "right_rear_wheel", "right_front_wheel")
"""DeepRacer's wheel link names, in its order."""
STEERING_JOINTS = ("left_steering_hinge_joint", "right_steering_hinge_joint")
CAR_GEOM_GROUP = 3
"""Car geoms live in a group the camera does not draw and the LIDAR does not see."""

WHEEL_MAX_TORQUE_NM = 2.0
"""Per wheel motor. The wheels spin free of the floor and reach the commanded rad/s within ≈ 2 ms (as the fit's
twin assumes); how fast the car follows is the tyre model's drive force (`tyres.py`)."""
WHEEL_VELOCITY_GAIN = 0.08
STEERING_KP = 20.0
"""Steering servo stiffness (N·m/rad); the velocity gain follows from the fitted time constant (`steering_kv`)."""
HINGE_DAMPING = 0.02
HINGE_ARMATURE = 0.0005
HINGE_RADIUS_M = 0.008
_HINGE_AXIS_INERTIA_KGM2 = HINGE_ARMATURE + 0.4 * (
    WHEEL_MASS_KG * WHEEL_RADIUS_M**2 + HINGE_MASS_KG * HINGE_RADIUS_M**2
)
TYRE_UPDATE_SUBSTEPS = 2
"""MuJoCo steps per tyre-force update (1/120 s at the env's 1/240 s): the tyre model is Python, so half as many
updates halve its cost; 8 ms is well inside the fastest tyre mode (≈ 13 ms, sliding sideways at the slip-speed floor)
and the fit's twin integrates at the same rate (8 steps per 67 ms row)."""
URDF_CHASSIS_INERTIA_KGM2 = (0.010609, 0.050409, 0.05865)
"""The SimApp URDF's chassis inertia (ixx, iyy, izz)."""
_WHEELS_YAW_INERTIA_KGM2 = (
    WHEEL_MASS_KG * (2 * (REAR_AXLE_X_M**2 + REAR_HALF_TRACK_M**2) + 2 * (FRONT_AXLE_X_M**2 + FRONT_HALF_TRACK_M**2))
    + 4 * 0.4 * WHEEL_MASS_KG * WHEEL_RADIUS_M**2
)
_HINGES_YAW_INERTIA_KGM2 = HINGE_MASS_KG * 2 * (FRONT_AXLE_X_M**2 + FRONT_HALF_TRACK_M**2)


def urdf_yaw_inertia_kgm2() -> float:
    """The whole car's inertia about the vertical from the URDF: chassis izz, wheels and hinges (`car_dynamics`'s
    URDF_YAW_INERTIA_KGM2, tested)."""
    return URDF_CHASSIS_INERTIA_KGM2[2] + _WHEELS_YAW_INERTIA_KGM2 + _HINGES_YAW_INERTIA_KGM2


def steering_kv(time_constant_s: float) -> float:
    """The servo's velocity gain that makes the hinge's slow mode a first-order lag of `time_constant_s` (the hinge
    with its wheel is a stiff, overdamped second-order system; its fast mode takes ≈ 2 ms)."""
    return STEERING_KP * time_constant_s + _HINGE_AXIS_INERTIA_KGM2 / time_constant_s - HINGE_DAMPING


def chassis_inertia_kgm2(yaw_inertia_kgm2: float) -> tuple[float, float, float]:
    """The chassis' diagonal inertia giving the whole car `yaw_inertia_kgm2` about the vertical. A rigid body needs
    ixx + iyy ≥ izz, so roll and pitch are scaled with yaw in the URDF's ratio (a flat body); with the tyre forces at
    the centre of mass the car hardly rolls or pitches on a flat floor."""
    yaw = yaw_inertia_kgm2 - _WHEELS_YAW_INERTIA_KGM2 - _HINGES_YAW_INERTIA_KGM2
    ixx, iyy, _ = URDF_CHASSIS_INERTIA_KGM2
    flat = 1.01 * yaw / (ixx + iyy)  # 1 % above the limit, so rounding never breaks it
    return flat * ixx, flat * iyy, yaw


CHASSIS_COM_Z_M = 0.075


def command_wheel_radius_m(simapp_version: float) -> float:
    """The radius the SimApp divides speed by to get wheel rad/s: 0.035 m for models of version ≥ 3, 0.0277 m for
    version 2, 0.1 m for version 1 (deepracer-simapp v5.3.3 `bundle/markov/agent_ctrl/utils.py` `get_wheel_radius`).
    The simulated wheel is always 0.035 m, so old models drive
    at 0.035/r of their nominal speed, as they do in DeepRacer."""
    if simapp_version >= 3.0:
        return COMMAND_WHEEL_RADIUS_M
    if simapp_version >= 2.0:
        return 0.0277
    return 0.1


def vertical_fov_deg(horizontal_fov_rad: float = CAMERA_HORIZONTAL_FOV_RAD, aspect: float = CAMERA_ASPECT) -> float:
    """MuJoCo's `fovy` for a camera with the given horizontal field of view and width/height aspect."""
    return math.degrees(2.0 * math.atan(math.tan(horizontal_fov_rad / 2.0) / aspect))


def clip_command(speed_mps: float, steering_deg: float) -> tuple[float, float]:
    """What the SimApp actually sends: speed in [0.1, 4] m/s, steering in [-30, 30] degrees."""
    return min(max(speed_mps, MIN_SPEED_MPS), MAX_SPEED_MPS), min(
        max(steering_deg, -MAX_STEERING_DEG), MAX_STEERING_DEG
    )


def camera_mount_m(simapp_version: float) -> tuple[float, float, float]:
    """Camera position on the car for a model's SimApp version."""
    return CAMERA_POS_M if simapp_version >= 3.0 else LEGACY_CAMERA_POS_M


def car_mjcf(
    friction: float,
    camera_names: tuple[tuple[str, float], ...],
    camera_pos_m: tuple[float, float, float] = CAMERA_POS_M,
    dynamics: CarDynamics = GAZEBO_DYNAMICS,
    camera_pitch_down_rad: float = CAMERA_PITCH_DOWN_RAD,
) -> str:
    """The car body (free joint at the origin) with wheels, steering hinges, cameras and the LIDAR site."""
    fovy = vertical_fov_deg()
    s, c = math.sin(camera_pitch_down_rad), math.cos(camera_pitch_down_rad)
    # Camera looks along its -z with +y up: x = car right (-y), up tilted forward by the pitch.
    cam_axes = f"0 -1 0 {s:.9f} 0 {c:.9f}"
    cameras = "\n".join(
        f'      <camera name="{name}" pos="{camera_pos_m[0]} {y:.4f} {camera_pos_m[2]}" xyaxes="{cam_axes}" fovy="{fovy:.9f}"/>'
        for name, y in camera_names
    )
    r = WHEEL_RADIUS_M
    ixx, iyy, izz = chassis_inertia_kgm2(dynamics.yaw_inertia_kgm2)
    wheel_geom = (
        # condim 1 and priority over the floor: a frictionless contact that carries the weight (the friction value
        # is the tyre model's μ).
        f'<geom type="sphere" size="{r}" mass="{WHEEL_MASS_KG}" friction="{friction} 0 0" '
        f'contype="2" conaffinity="1" group="{CAR_GEOM_GROUP}" condim="1" priority="1" rgba="0.1 0.1 0.1 1"/>'
    )
    rear = "\n".join(
        f'      <body name="{name}" pos="{REAR_AXLE_X_M} {side * REAR_HALF_TRACK_M} {r}">\n'
        f'        <joint name="{name}_joint" type="hinge" axis="0 1 0"/>\n        {wheel_geom}\n      </body>'
        for name, side in (("left_rear_wheel", 1), ("right_rear_wheel", -1))
    )
    front = "\n".join(
        f'      <body name="{side_name}_steering_hinge" pos="{FRONT_AXLE_X_M} {side * FRONT_HALF_TRACK_M} {r}">\n'
        f'        <joint name="{side_name}_steering_hinge_joint" type="hinge" axis="0 0 1" range="-{STEERING_LIMIT_RAD} {STEERING_LIMIT_RAD}" '
        f'damping="{HINGE_DAMPING}" armature="{HINGE_ARMATURE}"/>\n'
        f'        <geom type="sphere" size="{HINGE_RADIUS_M}" mass="{HINGE_MASS_KG}" contype="0" conaffinity="0" group="{CAR_GEOM_GROUP}"/>\n'
        f'        <body name="{side_name}_front_wheel">\n'
        f'          <joint name="{side_name}_front_wheel_joint" type="hinge" axis="0 1 0"/>\n          {wheel_geom}\n'
        f"        </body>\n      </body>"
        for side_name, side in (("left", 1), ("right", -1))
    )
    return f"""
    <body name="car" pos="0 0 0">
      <freejoint name="car_free"/>
      <inertial pos="0 0 {CHASSIS_COM_Z_M}" mass="{CHASSIS_MASS_KG:.6f}" diaginertia="{ixx:.6f} {iyy:.6f} {izz:.6f}"/>
      <geom name="chassis" type="box" size="0.15 0.07 0.025" pos="0 0 {CHASSIS_COM_Z_M}"
            contype="2" conaffinity="1" group="{CAR_GEOM_GROUP}" rgba="0.2 0.2 0.25 1"/>
{cameras}
      <site name="lidar" pos="{LIDAR_POS_M[0]} {LIDAR_POS_M[1]} {LIDAR_POS_M[2]}" size="0.01" group="{CAR_GEOM_GROUP}"/>
{rear}
{front}
    </body>"""


def car_actuators_mjcf(dynamics: CarDynamics = GAZEBO_DYNAMICS) -> str:
    wheels = "\n".join(
        f'    <velocity name="{name}_motor" joint="{name}_joint" kv="{WHEEL_VELOCITY_GAIN}" '
        f'forcelimited="true" forcerange="-{WHEEL_MAX_TORQUE_NM} {WHEEL_MAX_TORQUE_NM}"/>'
        for name in WHEEL_NAMES
    )
    steering = "\n".join(
        f'    <position name="{joint}_servo" joint="{joint}" kp="{STEERING_KP}" kv="{steering_kv(dynamics.steering_time_constant_s):.6f}" '
        f'ctrllimited="true" ctrlrange="-{STEERING_LIMIT_RAD} {STEERING_LIMIT_RAD}"/>'
        for joint in STEERING_JOINTS
    )
    return f"  <actuator>\n{wheels}\n{steering}\n  </actuator>"


@dataclass(frozen=True)
class CarPose:
    """What DeepRacer reads from the car each step."""

    origin_x_m: float
    origin_y_m: float
    yaw_rad: float
    model_point: tuple[float, float]
    """Front of car: origin + R(q)·[0.14, 0, 0] (x, y)."""
    wheel_xs: np.ndarray
    wheel_ys: np.ndarray


class Car:
    """Index bookkeeping for the car inside a compiled model: teleport, command, read the pose."""

    FRONT_OF_CAR_M = 0.14

    def __init__(
        self,
        model: mujoco.MjModel,
        command_wheel_radius: float = COMMAND_WHEEL_RADIUS_M,
        tyre_params: TyreParams | None = None,
    ) -> None:
        """`tyre_params`: the tyres the model was built with (`CarDynamics.tyres`; None = the default car's)."""
        self.command_wheel_radius = command_wheel_radius
        self.body_id = model.body("car").id
        joint = model.joint("car_free")
        self.qpos_adr = int(joint.qposadr[0])
        self.dof_adr = int(joint.dofadr[0])
        self.wheel_body_ids = np.array([model.body(name).id for name in WHEEL_NAMES])
        self.wheel_actuators = np.array([model.actuator(f"{name}_motor").id for name in WHEEL_NAMES])
        self.steering_actuators = np.array([model.actuator(f"{joint}_servo").id for joint in STEERING_JOINTS])
        self.car_dofs = np.arange(model.body_dofadr[self.body_id], model.nv)
        """The car's dofs are the last ones of the model (its body is the last subtree)."""
        self.car_qpos = np.arange(self.qpos_adr, model.nq)
        self.tyres = self._tyres(model, tyre_params or GAZEBO_DYNAMICS.tyres)

    def _tyres(self, model: mujoco.MjModel, params: TyreParams | None) -> Tyres:
        return Tyres(
            model,
            self.body_id,
            self.qpos_adr,
            self.dof_adr,
            [int(model.joint(joint).qposadr[0]) for joint in STEERING_JOINTS],
            self.wheel_actuators.tolist(),
            int(model.body_geomadr[self.wheel_body_ids[0]]),
            FRONT_AXLE_X_M,
            REAR_AXLE_X_M,
            params,
        )

    def retune(
        self,
        model: mujoco.MjModel,
        tyre_params: TyreParams,
        steering_time_constant_s: float,
        yaw_inertia_kgm2: float,
    ) -> None:
        """Change the fitted dynamics constants of a compiled model in place (for the leave-one-file-out replay)."""
        model.body_inertia[self.body_id] = chassis_inertia_kgm2(yaw_inertia_kgm2)
        model.actuator_biasprm[self.steering_actuators, 2] = -steering_kv(steering_time_constant_s)
        self.tyres = self._tyres(model, tyre_params)

    def step(self, model: mujoco.MjModel, data: mujoco.MjData, substeps: int) -> None:
        """Advance the physics by `substeps` MuJoCo steps, the tyre forces recomputed every TYRE_UPDATE_SUBSTEPS."""
        while substeps > 0:
            self.tyres.apply(data)
            steps = min(TYRE_UPDATE_SUBSTEPS, substeps)
            mujoco.mj_step(model, data, steps)
            substeps -= steps

    def teleport(self, model: mujoco.MjModel, data: mujoco.MjData, x_m: float, y_m: float, yaw_rad: float) -> None:
        """Put the car at rest on the ground at (x, y) with heading yaw; wheels and hinges straight."""
        data.qpos[self.car_qpos] = model.qpos0[self.car_qpos]
        data.qpos[self.qpos_adr : self.qpos_adr + 3] = (x_m, y_m, 0.0)
        data.qpos[self.qpos_adr + 3 : self.qpos_adr + 7] = (math.cos(yaw_rad / 2), 0.0, 0.0, math.sin(yaw_rad / 2))
        data.qvel[self.car_dofs] = 0.0
        data.qacc_warmstart[self.car_dofs] = 0.0
        data.ctrl[:] = 0.0
        mujoco.mj_forward(model, data)

    def command(self, data: mujoco.MjData, speed_mps: float, steering_deg: float) -> None:
        """Same wheel angular velocity on all four wheels, same angle on both hinges."""
        data.ctrl[self.wheel_actuators] = speed_mps / self.command_wheel_radius
        data.ctrl[self.steering_actuators] = math.radians(steering_deg)

    def pose(self, data: mujoco.MjData) -> CarPose:
        pos = data.xpos[self.body_id]
        mat = data.xmat[self.body_id]
        # Heading = yaw of the body's x axis (scipy 'zyx' euler yaw for a near-level car).
        yaw = math.atan2(mat[3], mat[0])
        model_point = (float(pos[0] + self.FRONT_OF_CAR_M * mat[0]), float(pos[1] + self.FRONT_OF_CAR_M * mat[3]))
        wheels = data.xpos[self.wheel_body_ids]
        return CarPose(float(pos[0]), float(pos[1]), yaw, model_point, wheels[:, 0].copy(), wheels[:, 1].copy())

    def speed_mps(self, data: mujoco.MjData) -> float:
        """Measured planar speed of the car origin (for tests and diagnostics; DeepRacer reports commands)."""
        vel = data.qvel[self.dof_adr : self.dof_adr + 2]
        return float(math.hypot(vel[0], vel[1]))
