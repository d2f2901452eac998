"""The car's dynamics constants as one value (`EnvConfig.car_dynamics`) and its presets, the car profiles.
MuJoCo-free, so the config can name them without importing the simulator.

* `GAZEBO_DYNAMICS`: what policies trained in DeepRacer's Gazebo lap with in racer's simulator, chosen closed loop
  with real policies (`python -m benchmarks transfer`; docs/car-and-camera.md).
* `SIMTRACE_FIT_DYNAMICS`: the constants fitted open loop on the real simtraces (research/tyre_fit/).
* `SIMAPP5_ROS1_DYNAMICS`, `SIMAPP6_ROS2_DYNAMICS`: DeepRacer's car per SimApp generation, built from the SimApp's
  URDF, contact and controller files (`car.simapp_profiles`).
* `CONSOLE2020_FIT_DYNAMICS`: fitted on the DeepRacer console's 2020 log (research/console2020_fit/): the `2019`
  generation's car by its data, but the sample checkpoints lap none of 10 with it, so `2019` keeps `gazebo`.
* `SIMAPP6_FIT_DYNAMICS`: the `simapp6` generation's car, its source facts kept and the rest fitted on DeepRacer on
  AWS's 2026 logs (research/simapp6_fit/).

A generation (`generations.py`) names the profile its car is; the profiles stay available for studies.
"""

from __future__ import annotations

from dataclasses import dataclass

from racer.shared.sim.car import simapp_profiles as simapp
from racer.shared.sim.car.tyres import GAZEBO_TYRES, TyreParams

STEERING_TIME_CONSTANT_S = 0.0166
"""How fast the hinges follow a new angle, fitted with the tyre model on real simtraces (research/tyre_fit/);
both `gazebo` and `simtrace-fit` use it (closed loop, real policies lose laps with a slower servo)."""
YAW_INERTIA_KGM2 = 0.475
"""The whole car's inertia about the vertical, fitted with the tyre model on real simtraces: the real cars' yaw rate
carries on between steps as if the car were ≈ 6× as hard to turn as the URDF's (URDF_YAW_INERTIA_KGM2)."""
URDF_YAW_INERTIA_KGM2 = 0.079886
"""The whole car's inertia about the vertical from the SimApp URDF: chassis izz 0.05865 kg·m² plus the wheels and
hinges at their positions (`car.urdf_yaw_inertia_kgm2()`, tested)."""


@dataclass(frozen=True)
class CarDynamics:
    """The car's dynamics constants (one `EnvConfig.car_dynamics`): the tyre model, the steering servo's time
    constant and the whole car's yaw inertia. Each can be changed on its own with `dataclasses.replace`."""

    tyres: TyreParams
    steering_time_constant_s: float
    yaw_inertia_kgm2: float


SIMTRACE_FIT_DYNAMICS = CarDynamics(TyreParams(), STEERING_TIME_CONSTANT_S, YAW_INERTIA_KGM2)
"""The constants fitted on the real simtraces (console 2022 / DRfC runs, research/tyre_fit/): the open-loop
replay's best car, but real DeepRacer policies do not lap with it (soft front axle, 6× the URDF's yaw inertia)."""
GAZEBO_DYNAMICS = CarDynamics(GAZEBO_TYRES, STEERING_TIME_CONSTANT_S, URDF_YAW_INERTIA_KGM2)
"""Stiff equal-axle tyres rolling at the commanded speed, the URDF's yaw inertia and the fast servo (racer's default
car until generations). Policies trained in DeepRacer's Gazebo lap racer's tracks with it, and not with the simtrace fit or the
profiles built from DeepRacer's source (`python -m benchmarks transfer`). Against the source it keeps two constants: a servo
≈ 30× faster than the ROS 1 hinge PD's 0.5 s and a peak grip ≈ 2× a Coulomb μ 0.5, the two source facts that cost
real policies their laps (docs/car-and-camera.md)."""
SIMAPP5_ROS1_DYNAMICS = CarDynamics(
    simapp.source_tyres(), simapp.ROS1_STEERING_TIME_CONSTANT_S, simapp.ROS1_YAW_INERTIA_KGM2
)
"""The ROS 1 / Gazebo classic SimApp's car (deepracer-simapp v5.3.3; the console until 2025, DRfC 5), from its
source: the URDF's masses and yaw inertia (0.0803 kg·m²), the hinge PD (p 1, d 0.5) as a 0.50 s servo, rigid μ 0.5
wheels (peak grip 1) driven to the 0.036 m mesh's rolling speed (1.029 × commanded). Only the cornering and drive
stiffness are racer's (the stiffest its tyre update resolves; `car.simapp_profiles`)."""
SIMAPP6_ROS2_DYNAMICS = CarDynamics(
    simapp.source_tyres(), simapp.ROS2_STEERING_TIME_CONSTANT_S, simapp.ROS2_YAW_INERTIA_KGM2
)
"""The ROS 2 / gz-sim SimApp's car (v6.0.5; DeepRacer on AWS, DRfC 6), models of version >= 5: as the ROS 1 car but
with 0.98 kg more on the camera links and shell (yaw inertia 0.0828 kg·m² for racer's body) and gz_ros2_control's
60 Hz position loop on the hinges (gain 0.1: a 0.158 s servo); the wheels are velocity-commanded."""
SIMAPP6_FIT_DYNAMICS = CarDynamics(
    TyreParams(
        front_cornering_stiffness_n_per_rad=79.34,
        rear_cornering_stiffness_n_per_rad=161.77,
        front_peak_grip=1.0,
        rear_peak_grip=1.0,
        drive_stiffness_n_per_mps=99.02,
        max_drive_force_n=42.24,
        rolling_radius_m=simapp.WHEEL_MESH_RADIUS_M,
    ),
    steering_time_constant_s=0.0664,
    yaw_inertia_kgm2=0.1333,
)
"""The `simapp6` generation's car: fitted on DeepRacer on AWS's March 2026 logs (SimApp v6.0.5, Spain_track; three
files, research/simapp6_fit/: `python -m research.simapp6_fit`, the constants fitted on all three). Held out (each
file replayed with the constants fitted on the other two) the median position error after 1 s is 0.139 m at
1.25-1.75 m/s and 0.105 m at >= 1.75 m/s, against 0.56 and 0.37 m for the car built from the v6.0.5 files alone.
Kept from the source, not fitted: μ 0.5 Coulomb wheels (peak grip 1 × μ × load) rolling on the 0.036 m wheel mesh.
Fitted: the cornering stiffness (an understeering car, front half the rear), a drive that reaches the commanded
speed in ≈ 0.07 s and at most 6.4 m/s², a hinge servo of 0.066 s (the logs reject the 0.158 s read from
gz_ros2_control's position loop: held there, the held-out errors are 0.35 and 0.28 m) and a yaw inertia of 0.133 kg·m²
(the v6 URDF gives 0.083 for racer's body)."""
CONSOLE2020_FIT_DYNAMICS = CarDynamics(
    TyreParams(
        front_cornering_stiffness_n_per_rad=15.78,
        rear_cornering_stiffness_n_per_rad=13.09,
        front_peak_grip=1.0,
        rear_peak_grip=1.0,
        drive_stiffness_n_per_mps=55.97,
        max_drive_force_n=simapp.friction_drive_cap_n(),
        rolling_radius_m=simapp.WHEEL_MESH_RADIUS_M,
    ),
    steering_time_constant_s=0.0599,
    yaw_inertia_kgm2=0.1647,
)
"""The car of the one log of the `2019` generation's simulator: the DeepRacer console's evaluation of September 2020 (Gazebo classic,
ROS 1, a model of version 3 as the 2019 sample checkpoints; `Belille`, three episodes at 0.33-1 m/s;
research/console2020_fit/: `python -m research.console2020_fit`, the constants fitted on all three). Held out (each
episode replayed with the constants fitted on the other two) the median position error after 1 s is 0.070 m at
0-0.75 m/s and 0.080 m at 0.75-1.25 m/s. Kept from the ROS 1 files: μ 0.5 Coulomb wheels on the 0.036 m mesh and the
drive's friction limit (μ × weight), which the log never reaches. Fitted: soft, nearly equal axles (15.8 / 13.1
N/rad), a 0.060 s servo, a yaw inertia of 0.165 kg·m². The log holds no speed above 1.25 m/s: at the sample
checkpoints' 2 m/s this car is an extrapolation, and closed loop they lap 0 of 10 with it (mean progress 12.8 and
25.6 %, `python -m benchmarks transfer --car-profile console2020-fit`), so `2019` keeps `gazebo`."""
CAR_DYNAMICS: dict[str, CarDynamics] = {
    "gazebo": GAZEBO_DYNAMICS,
    "simtrace-fit": SIMTRACE_FIT_DYNAMICS,
    "simapp5-ros1": SIMAPP5_ROS1_DYNAMICS,
    "simapp6-ros2": SIMAPP6_ROS2_DYNAMICS,
    "simapp6-fit": SIMAPP6_FIT_DYNAMICS,
    "console2020-fit": CONSOLE2020_FIT_DYNAMICS,
}
"""The presets by name: the car profiles (`RACER_CAR_PROFILE`, `--car-profile`; `python -m benchmarks fidelity --car`)."""
CAR_PROFILE_NAMES: tuple[str, ...] = tuple(CAR_DYNAMICS)
DEFAULT_CAR_PROFILE = "simapp6-fit"
"""The car of the default generation (`generations.DEFAULT_GENERATION`, tested equal): what a worker, an evaluation
and the benches drive unless a generation or a car profile is named."""


def car_profile(name: str) -> CarDynamics:
    """The car profile called `name`; an unknown name is a ValueError naming RACER_CAR_PROFILE and the valid names."""
    try:
        return CAR_DYNAMICS[name]
    except KeyError:
        raise ValueError(
            f"RACER_CAR_PROFILE: unknown car profile {name!r}; choose one of {', '.join(CAR_PROFILE_NAMES)}"
        ) from None
