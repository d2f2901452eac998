"""The car's tyres: horizontal forces from a dynamic bicycle model, applied to the MuJoCo chassis every substep.

The wheel geoms touch the floor without friction (they only carry the weight); what drives and steers the car is
computed here from the chassis velocity, the steering hinges' angle and the wheels' spin:

* per axle, a lateral force from the axle's slip angle, linear (cornering stiffness) and then saturating (tanh)
  at a peak of grip × μ × the axle's static load, μ being the world's tyre friction. The front force acts
  perpendicular to the steered wheels;
* a drive force along the car that pulls the chassis towards the wheels' rolling speed (the motors' commanded spin
  × rolling radius: the free wheels reach it within ≈ 2 ms), linear in the speed difference and capped.

The forces act at the centre of mass (no load transfer, no roll): yaw comes from the axles' lever arms, and the
chassis' yaw inertia makes the yaw rate carry on between steps, as the real DeepRacer simtraces show. A Coulomb
contact (a sphere tyre) cannot: it understeers at small steering angles, oversteers at full lock and resets the yaw
rate within a step. The default constants are fitted on real simtraces (research/tyre_fit/ in the repository;
docs/car-and-camera.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # the constants are MuJoCo-free (EnvConfig names them); Tyres only annotates with mujoco's types
    from racer.shared.sim.scene._mujoco import mujoco

GRAVITY_MPS2 = 9.81


@dataclass(frozen=True)
class TyreParams:
    """The tyre model's constants; the defaults are fitted on the real simtraces (research/tyre_fit/). The
    env's default car uses `GAZEBO_TYRES` instead (what policies trained in DeepRacer's Gazebo drive with)."""

    front_cornering_stiffness_n_per_rad: float = 50.93
    rear_cornering_stiffness_n_per_rad: float = 104.94
    front_peak_grip: float = 1.96
    """Peak lateral force of the front axle / (μ × its static load): ≈ 1 × the load on the base world (μ 0.5)."""
    rear_peak_grip: float = 1.96
    """The rear axle never saturates in the real logs (the fit runs off to > 100); taken equal to the front's."""
    drive_stiffness_n_per_mps: float = 47.23
    """Drive force per m/s of rolling speed above the chassis' forward speed (≈ 0.14 s speed time constant)."""
    max_drive_force_n: float = 21.56
    """Cap of the drive (and braking) force: ≈ 3.3 m/s² for the 6.56 kg car."""
    rolling_radius_m: float = 0.03928
    """Effective rolling radius: the real cars cover ≈ 1.12 × the commanded speed (wheel rad/s = speed / 0.035)."""
    min_slip_speed_mps: float = 0.3
    """Below this forward speed slip angles are taken at this speed: lateral grip becomes viscous, no blow-up at rest."""

    def __post_init__(self) -> None:
        for name in self.__dataclass_fields__:
            if not getattr(self, name) > 0:
                raise ValueError(f"TyreParams.{name} must be > 0, got {getattr(self, name)}")


GAZEBO_TYRES = TyreParams(
    front_cornering_stiffness_n_per_rad=300.0,
    rear_cornering_stiffness_n_per_rad=300.0,
    rolling_radius_m=0.035,
)
"""The tyres of the env's default car (`car.GAZEBO_DYNAMICS`): stiff and equal on both axles (the car follows its
wheels almost kinematically, neutral steer, until the axles saturate at the fitted peak grip × μ × load), rolling at
the commanded speed. Closed loop, real policies trained in DeepRacer's Gazebo lap with them and not with the
simtrace fit's soft, understeering front axle (front 50.9 vs rear 104.9 N/rad) and 1.12× speed
(docs/car-and-camera.md); the exact stiffness matters little as long as both axles are equal and stiff."""


class Tyres:
    """The tyre forces of one car in one compiled model (indices resolved once)."""

    def __init__(
        self,
        model: mujoco.MjModel,
        body_id: int,
        qpos_adr: int,
        dof_adr: int,
        hinge_qpos: list[int],
        wheel_actuators: list[int],
        wheel_geom: int,
        front_axle_x_m: float,
        rear_axle_x_m: float,
        params: TyreParams | None = None,
    ) -> None:
        self.params = params or TyreParams()
        self.body_id = body_id
        self.dof_adr = dof_adr
        # One slice read per array and step: the free joint's quaternion and both hinges, the wheel motors' commands.
        self._qpos_span = slice(qpos_adr, max(hinge_qpos) + 1)
        self._quat_w, self._quat_z = 3, 6
        self._hinges = [adr - qpos_adr for adr in hinge_qpos]
        if sorted(wheel_actuators) != list(range(min(wheel_actuators), min(wheel_actuators) + len(wheel_actuators))):
            raise ValueError(f"the wheel motors must be consecutive actuators, got ids {wheel_actuators}")
        self._wheel_ctrl = slice(min(wheel_actuators), min(wheel_actuators) + len(wheel_actuators))
        com_x_m = float(model.body_ipos[body_id][0])
        self.front_arm_m = front_axle_x_m - com_x_m
        self.rear_arm_m = com_x_m - rear_axle_x_m
        wheelbase_m = self.front_arm_m + self.rear_arm_m
        weight_n = float(model.body_subtreemass[body_id]) * GRAVITY_MPS2
        mu = float(model.geom_friction[wheel_geom][0])
        p = self.params
        self.front_peak_n = p.front_peak_grip * mu * weight_n * self.rear_arm_m / wheelbase_m
        self.rear_peak_n = p.rear_peak_grip * mu * weight_n * self.front_arm_m / wheelbase_m
        self.front_stiffness_per_peak = p.front_cornering_stiffness_n_per_rad / self.front_peak_n
        self.rear_stiffness_per_peak = p.rear_cornering_stiffness_n_per_rad / self.rear_peak_n
        self.rolling_per_wheel_rad_s = p.rolling_radius_m / len(wheel_actuators)

    def apply(self, data: mujoco.MjData) -> None:
        """Set the chassis' applied force and torque for the next physics step from the current state."""
        p = self.params
        qpos = data.qpos[self._qpos_span].tolist()
        # A near-level car: heading from the quaternion's yaw part, yaw rate = angular velocity about body z.
        yaw = 2.0 * math.atan2(qpos[self._quat_z], qpos[self._quat_w])
        cos_yaw, sin_yaw = math.cos(yaw), math.sin(yaw)
        vx_w, vy_w, _, _, _, yaw_rate = data.qvel[self.dof_adr : self.dof_adr + 6].tolist()
        forward = cos_yaw * vx_w + sin_yaw * vy_w
        lateral = cos_yaw * vy_w - sin_yaw * vx_w
        steer = 0.5 * (qpos[self._hinges[0]] + qpos[self._hinges[1]])
        slip_speed = max(abs(forward), p.min_slip_speed_mps)
        front_slip = math.atan2(lateral + self.front_arm_m * yaw_rate, slip_speed) - steer
        rear_slip = math.atan2(lateral - self.rear_arm_m * yaw_rate, slip_speed)
        front = -self.front_peak_n * math.tanh(self.front_stiffness_per_peak * front_slip)
        rear = -self.rear_peak_n * math.tanh(self.rear_stiffness_per_peak * rear_slip)
        rolling_mps = self.rolling_per_wheel_rad_s * sum(data.ctrl[self._wheel_ctrl].tolist())
        drive = p.drive_stiffness_n_per_mps * (rolling_mps - forward)
        drive = min(max(drive, -p.max_drive_force_n), p.max_drive_force_n)
        cos_steer, sin_steer = math.cos(steer), math.sin(steer)
        fx = drive - front * sin_steer
        fy = rear + front * cos_steer
        applied = data.xfrc_applied[self.body_id]
        applied[0] = cos_yaw * fx - sin_yaw * fy
        applied[1] = sin_yaw * fx + cos_yaw * fy
        applied[5] = self.front_arm_m * front * cos_steer - self.rear_arm_m * rear
