"""DeepRacer's car per SimApp generation, built from the SimApp's own files (the `simapp5-ros1` and `simapp6-ros2`
car profiles of `car.dynamics.CAR_DYNAMICS`). MuJoCo-free: only numbers and the formulas that turn them into
racer's `CarDynamics` constants.

Sources (aws-deepracer-community/deepracer-simapp; facts read, no code copied; docs/deepracer-sources.md):

* **ROS 1 / Gazebo classic**, tag `v5.3.3` (commit 608b024b; the console until 2025, DeepRacer-for-Cloud 5):
  `bundle/urdf/deepracer/deepracer_single_cam.urdf` (masses, inertias, joints), `racecar.gazebo` (wheel contact),
  `bundle/meshes/deepracer/left_rear_wheel.STL` (wheel radius), `bundle/src/deepracer_simulation_environment/
  config/racecar_control.yaml` (models of version < 5: effort controllers with PIDs under gazebo_ros_control) and
  `racecar_control_kinematics.yaml` (version >= 5: velocity / position interfaces, the same gains as
  `gazebo_ros_control/pid_gains`, so the same PID laws act through the plugin); `launch/racecar.launch` picks one.
  `bundle/worlds/reinvent_base.world` sets no `<physics>`: Gazebo's default, ODE at 1 ms.
* **ROS 2 / gz-sim**, tag `v6.0.5` (commit 116686f4; DeepRacer on AWS, DeepRacer-for-Cloud 6): the same files. The
  URDF adds mass to the camera links and the shell; the controllers (`controller_manager` `update_rate: 60`) are
  forward-command groups: `position_controllers/JointGroupPositionController` on the hinges and, for models of
  version >= 5, `velocity_controllers/JointGroupVelocityController` on the wheels. Forward-command controllers read
  no `pid:` block; gz_ros2_control (ros-controls/gz_ros2_control, `GazeboSimSystem::write`) turns a position command
  into a joint velocity command `gain × update_rate × (target − position)` with gain 0.1 by default, and a velocity
  command into the joint's velocity. (Models of version < 5 get `JointGroupEffortController` wheels, which apply the
  published rad/s as a torque with no speed loop; not modelled.) The world names no physics engine: DART at 1 ms.

What the sources leave open, racer chooses and says so: the tyre contact is rigid until it slides (ODE and DART
friction constraints with μ 0.5, no slip compliance), stiffer than racer's explicit 120 Hz tyre update can hold, so
the cornering and drive stiffness are the stiffest that update resolves (`resolvable_*`). Mass: racer's body keeps the
v5 URDF's 6.56 kg; every force of the model scales with mass, so a heavier car is the same motion with the yaw inertia
scaled by racer's mass / its mass (`yaw_inertia_for_racer_body`). The ROS 2 car's centre of mass moves 7.7 mm forward
(an understeer gradient of ≈ 0.002 rad per m/s², a 20th of the simtrace fit's): ignored.
"""

from __future__ import annotations

import math

from racer.shared.sim.car.tyres import GRAVITY_MPS2, TyreParams

# --- v5.3.3 `deepracer_single_cam.urdf` (unchanged in v6.0.5 unless named) ---
CHASSIS_MASS_KG = 5.0
CHASSIS_IZZ_KGM2 = 0.05865
WHEEL_MASS_KG = 0.34055
WHEEL_IZZ_KGM2 = 0.00026046
"""A wheel's inertia about its own vertical (= ixx; the spin axis iyy is 0.00041226)."""
HINGE_MASS_KG = 0.1
HINGE_IZZ_KGM2 = 4e-6
WHEEL_POSITIONS_M = ((-0.081663, 0.08105), (-0.081663, -0.08105), (0.082311, 0.079601), (0.082311, -0.079601))
"""(x, y) of rear-left, rear-right wheel joints and of the two steering hinges (the front wheels sit on them)."""
JOINT_EFFORT_LIMIT_NM = 10.0
"""Every wheel and hinge joint: effort 10, velocity 100 rad/s. v5.3.3 declares the hinges `continuous` (their ±1 rad
`lower`/`upper` are not enforced); v6.0.5 makes them `revolute` with ±1 rad."""
HINGE_LIMIT_RAD = 1.0
V5_SENSOR_MASS_KG = 0.001 + 0.001
"""v5.3.3: zed_camera_link 1e-3 kg and camera_link 0.001 kg; car_body_link_v3 0 kg."""
WHEEL_MESH_RADIUS_M = 0.036
"""Half the height of the wheel's collision mesh (`bundle/meshes/deepracer/*_wheel.STL`: ±0.036 m in x and z)."""
COMMAND_WHEEL_RADIUS_M = 0.035
"""The SimApp sends speed / 0.035 m as wheel rad/s (models of version >= 3; `car.command_wheel_radius_m`)."""
WHEEL_MU = 0.5
"""`racecar.gazebo`: mu1 = mu2 = 0.5 on every wheel, contact kp 1e6 N/m, kd 1 N·s/m (chassis mu 0)."""

# --- v5.3.3 `racecar_control.yaml` (and `_kinematics.yaml`'s `gazebo_ros_control/pid_gains`) ---
WHEEL_P_NM_PER_RAD_S = (1.0, 1.0, 0.5, 0.5)
"""Velocity PID of rear-left, rear-right, front-left, front-right wheels: P only (i 0, d 0)."""
HINGE_P_NM_PER_RAD = 1.0
HINGE_D_NMS_PER_RAD = 0.5
"""Hinge position PID: p 1.0, i 0, d 0.5 (the derivative on the error: −d × hinge rate for a held command)."""

# --- v6.0.5 ---
V6_EXTRA_LINKS = (
    # (mass kg, izz kg·m², x of the mass in the chassis frame m): zed_camera_link at its joint (0.091711, 0, 0.080023)
    # pitched 0.2618 rad; camera_link 0.044755 m ahead and 0.04 m above it in that pitched frame; car_body_link_v3
    # at (−0.0762, 0, 2e-5). Each inertial's first <origin> is (0, 0, 0). The camera links' ixx = izz, so the pitch
    # leaves their izz as is.
    (0.34055, 0.00026046, 0.091711),
    (0.34055, 0.00026046, 0.091711 + 0.044755 * math.cos(0.2618) + 0.04 * math.sin(0.2618)),
    (0.3, 0.003, -0.0762),
)
CONTROLLER_RATE_HZ = 60.0
"""v6.0.5 `controller_manager` `update_rate` (v5.3.3's 60 is only the joint-state publish rate; gazebo_ros_control
runs the controllers every 1 ms physics step)."""
GZ_POSITION_GAIN = 0.1
"""gz_ros2_control's default `position_proportional_gain` (the SimApp sets none)."""

# --- racer's side ---
TYRE_UPDATE_HZ = 120.0
"""racer recomputes the tyre forces every 1/120 s (`car.TYRE_UPDATE_SUBSTEPS` at the env's 1/240 s step)."""
SLOWEST_COMMANDED_SPEED_MPS = 1.0
"""The sample models' slowest action (the reference speed of the stiffest resolvable tyre)."""


def urdf_mass_kg(extra_links: tuple[tuple[float, float, float], ...] = ()) -> float:
    """Chassis, four wheels and two hinges, plus `extra_links` (without the v5 URDF's 2 g of camera links)."""
    return CHASSIS_MASS_KG + 4 * WHEEL_MASS_KG + 2 * HINGE_MASS_KG + sum(mass for mass, _, _ in extra_links)


def urdf_yaw_inertia_kgm2(extra_links: tuple[tuple[float, float, float], ...] = ()) -> float:
    """The whole car's inertia about the vertical through its centre of mass (chassis izz, wheels and hinges at their
    joints, `extra_links`). Without extra links it equals racer's `car.urdf_yaw_inertia_kgm2()` (tested)."""
    wheels = sum(WHEEL_MASS_KG * (x * x + y * y) + WHEEL_IZZ_KGM2 for x, y in WHEEL_POSITIONS_M)
    hinges = sum(HINGE_MASS_KG * (x * x + y * y) + HINGE_IZZ_KGM2 for x, y in WHEEL_POSITIONS_M[2:])
    extra = sum(mass * x * x + izz for mass, izz, x in extra_links)
    com_x = sum(mass * x for mass, _, x in extra_links) / urdf_mass_kg(extra_links)  # the rest is centred in x
    return CHASSIS_IZZ_KGM2 + wheels + hinges + extra - urdf_mass_kg(extra_links) * com_x**2


def yaw_inertia_for_racer_body(yaw_inertia_kgm2: float, mass_kg: float) -> float:
    """The yaw inertia that gives racer's 6.56 kg body the same yaw response as a car of `mass_kg`: all forces scale
    with mass, so only inertia / mass matters."""
    return yaw_inertia_kgm2 * urdf_mass_kg() / mass_kg


def hinge_axis_inertia_kgm2() -> float:
    """What a steering hinge turns: the hinge link and its wheel about the vertical through the hinge."""
    return HINGE_IZZ_KGM2 + WHEEL_IZZ_KGM2


def pd_servo_time_constant_s(p: float = HINGE_P_NM_PER_RAD, d: float = HINGE_D_NMS_PER_RAD) -> float:
    """The ROS 1 hinge, J θ'' + d θ' + p θ = p θ_cmd (effort PD, J the hinge axis inertia): a heavily overdamped
    second-order system (ζ ≈ 15) whose slow pole sets the lag. Its time constant is 2J / (d − √(d² − 4pJ)) ≈ d / p
    = 0.5 s; the fast pole takes 0.5 ms. (The derivative kick of a new command, capped at 10 N·m for one 1 ms step,
    moves the hinge a further ≈ 0.02 rad at once: not modelled.)"""
    j = hinge_axis_inertia_kgm2()
    return 2.0 * j / (d - math.sqrt(d * d - 4.0 * p * j))


def gz_position_servo_time_constant_s(gain: float = GZ_POSITION_GAIN, rate_hz: float = CONTROLLER_RATE_HZ) -> float:
    """The ROS 2 hinge: every controller update (1/60 s) sets the joint velocity to gain × rate × error, held until
    the next update, so each update covers `gain` of the remaining error: a discrete first-order lag with
    τ = −1 / (rate × ln(1 − gain)) = 0.158 s (the continuous 1 / (gain × rate) would be 0.167 s)."""
    return -1.0 / (rate_hz * math.log(1.0 - gain))


def wheel_drive_stiffness_n_per_mps(p_gains: tuple[float, ...] = WHEEL_P_NM_PER_RAD_S) -> float:
    """The ROS 1 wheels' P loops pull the car towards their rolling speed with ΣP / r² N per m/s (2315 N/(m/s): a
    2.8 ms speed lag for the 6.56 kg car); the ROS 2 wheels are velocity-commanded, stiffer still."""
    return sum(p_gains) / WHEEL_MESH_RADIUS_M**2


def resolvable_drive_stiffness_n_per_mps() -> float:
    """[racer] The stiffest drive racer's explicit tyre update holds without overshoot: a speed lag of one update."""
    return urdf_mass_kg() * TYRE_UPDATE_HZ


def resolvable_cornering_stiffness_n_per_rad() -> float:
    """[racer] Per axle, for a rigid-until-sliding contact: the slip mode's time constant M·v / ΣC is one tyre update
    at the slowest commanded speed (faster, and the explicit update overshoots)."""
    return urdf_mass_kg() * SLOWEST_COMMANDED_SPEED_MPS * TYRE_UPDATE_HZ / 2.0


def friction_drive_cap_n() -> float:
    """All four wheels driven, each sliding at μ × its load: the drive (and brake) force tops out at μ × weight,
    μ g = 4.9 m/s². The joints' 10 N·m effort limit (278 N per wheel at 0.036 m) never binds."""
    return WHEEL_MU * urdf_mass_kg() * GRAVITY_MPS2


def source_tyres() -> TyreParams:
    """Both generations' tyres: rigid until μ 0.5 × the axle's load (peak grip 1), equal axles, the drive at the
    friction limit, rolling on the 0.036 m mesh while commanded for 0.035 m (1.029 × the commanded speed)."""
    stiffness = resolvable_cornering_stiffness_n_per_rad()
    return TyreParams(
        front_cornering_stiffness_n_per_rad=stiffness,
        rear_cornering_stiffness_n_per_rad=stiffness,
        front_peak_grip=1.0,
        rear_peak_grip=1.0,
        drive_stiffness_n_per_mps=resolvable_drive_stiffness_n_per_mps(),
        max_drive_force_n=friction_drive_cap_n(),
        rolling_radius_m=WHEEL_MESH_RADIUS_M,
    )


ROS1_STEERING_TIME_CONSTANT_S = pd_servo_time_constant_s()
ROS1_YAW_INERTIA_KGM2 = urdf_yaw_inertia_kgm2()
ROS2_MASS_KG = urdf_mass_kg(V6_EXTRA_LINKS)
ROS2_STEERING_TIME_CONSTANT_S = gz_position_servo_time_constant_s()
ROS2_YAW_INERTIA_KGM2 = yaw_inertia_for_racer_body(urdf_yaw_inertia_kgm2(V6_EXTRA_LINKS), ROS2_MASS_KG)
