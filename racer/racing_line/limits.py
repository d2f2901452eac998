"""What bounds a car's lap (`CarLimits`), read from the car profile and the world, not restated.

* top speed = the largest command (4 m/s) × the tyres' rolling radius / the command radius;
* lateral acceleration = the weaker axle's peak grip × the world's tyre μ × g (each axle saturates at peak grip × μ ×
  its static load, and in a steady turn each axle carries its share of the load);
* drive and brake = the drive force cap / the car's mass (racer's tyre model caps both alike and keeps them apart from
  the lateral force: no friction circle, `tyres.py`);
* curvature ≤ tan(the steering limit) / wheelbase;
* half a DeepRacer car's width (`object_poses.BOT_CAR_SIZE`, the shell) kept inside each border, so the whole car
  stays on the road.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from racer.shared.sim.car import vehicle as car
from racer.shared.sim.car.dynamics import CAR_DYNAMICS, CarDynamics
from racer.shared.sim.car.tyres import GRAVITY_MPS2
from racer.shared.sim.objects.poses import BOT_CAR_SIZE
from racer.shared.sim.scene.worlds import get_world


def profile_name(dynamics: CarDynamics) -> str:
    """The car profile's name of `dynamics` (`car_dynamics.CAR_DYNAMICS`), or "custom" for a car of no profile."""
    return next((name for name, known in CAR_DYNAMICS.items() if known == dynamics), "custom")


class LapTimeBoundError(ValueError):
    """The line cannot be computed for this track and car; the message names the track and why."""


@dataclass(frozen=True)
class CarLimits:
    """What bounds the car's lap: speeds, accelerations, the tightest turn and its half width."""

    top_speed_mps: float
    lateral_accel_mps2: float
    drive_accel_mps2: float
    brake_accel_mps2: float
    max_curvature_per_m: float
    half_width_m: float
    car_profile: str
    """The car profile the limits were read from (`profile_name`)."""
    world: str

    @classmethod
    def of_car(
        cls, dynamics: CarDynamics, world: str = "base", top_command_mps: float = car.MAX_SPEED_MPS
    ) -> CarLimits:
        """The limits of the car with `dynamics` in `world` (its tyre μ) driven at commands up to `top_command_mps`."""
        tyres = dynamics.tyres
        mu = get_world(world).tyre_friction
        drive_accel = tyres.max_drive_force_n / car.TOTAL_MASS_KG
        return cls(
            top_speed_mps=min(top_command_mps, car.MAX_SPEED_MPS) * tyres.rolling_radius_m / car.COMMAND_WHEEL_RADIUS_M,
            lateral_accel_mps2=min(tyres.front_peak_grip, tyres.rear_peak_grip) * mu * GRAVITY_MPS2,
            drive_accel_mps2=drive_accel,
            brake_accel_mps2=drive_accel,
            max_curvature_per_m=math.tan(math.radians(car.MAX_STEERING_DEG)) / car.WHEELBASE_M,
            half_width_m=BOT_CAR_SIZE.width_m / 2.0,
            car_profile=profile_name(dynamics),
            world=world,
        )

    def summary(self) -> dict:
        return {
            "car_profile": self.car_profile,
            "world": self.world,
            "top_speed_mps": round(self.top_speed_mps, 3),
            "lateral_accel_mps2": round(self.lateral_accel_mps2, 3),
            "drive_accel_mps2": round(self.drive_accel_mps2, 3),
            "brake_accel_mps2": round(self.brake_accel_mps2, 3),
            "min_turn_radius_m": round(1.0 / self.max_curvature_per_m, 3),
            "half_width_m": round(self.half_width_m, 4),
        }
