"""A DeepRacer generation: the look and the car of one era of DeepRacer's simulator, chosen together by one name
(`RACER_GENERATION`, `--generation`). MuJoCo-free, so the config can name them.

A user thinks in generations: "the simulator my model trained in". The car profiles (`car.dynamics.CAR_DYNAMICS`)
stay available for studies; `--car-profile` beside a generation replaces its car and `--world` picks the floor
within its look. Every constant of a generation's car and look is a fact from that generation's files or a fit to
its data (docs/car-and-camera.md says which):

* `2019`: Gazebo classic and ROS 1, the world the 2018-2019 sample model was trained in and its 92 frames were
  taken in (aws-deepracer-community/deepracer-core at 6d9f8481; `generation_looks.LOOK_2019`). Its car is the one
  exception to the rule below: `gazebo`, chosen closed loop with the sample checkpoints, because the car fitted on
  that era's one log (`console2020-fit`) laps none of them (docs/car-and-camera.md).
* `simapp5`: the ROS 1 SimApp up to v5.3.3 (the AWS console until 2025, DeepRacer-for-Cloud 5).
* `simapp6`: the ROS 2 / gz-sim SimApp v6.0.5 (DeepRacer on AWS, DeepRacer-for-Cloud 6): the default.
"""

from __future__ import annotations

from dataclasses import dataclass

from racer.shared.sim.car.dynamics import CarDynamics, car_profile
from racer.shared.sim.generations.looks import LOOK_2019, LOOK_SIMAPP5, LOOK_SIMAPP6, GenerationLook


@dataclass(frozen=True)
class Generation:
    """One generation: its look, its car (a car profile's name) and where each comes from."""

    name: str
    title: str
    car_profile: str
    """The car (`car.dynamics.CAR_DYNAMICS`) unless `--car-profile` replaces it."""
    look: GenerationLook
    sources: str
    """Where the look's and the car's constants come from (repository, path, tag), in a line."""

    @property
    def car(self) -> CarDynamics:
        return car_profile(self.car_profile)


GENERATIONS: dict[str, Generation] = {
    "2019": Generation(
        "2019",
        "Gazebo classic, ROS 1 (2018-2019 console)",
        "gazebo",
        LOOK_2019,
        "look: deepracer-core 6d9f8481 deepracer_simulation worlds/reinvent_*.world, models/reinvent_base, "
        "meshes/reinvent/walls.dae; osrf/gazebo_models sun/model.sdf; car: gazebo, chosen closed loop with the 2019 "
        "sample checkpoints, not a fact or a fit: the car fitted on that era's one log (console2020-fit, "
        "research/console2020_fit/) laps none of them, so the landing rule keeps gazebo",
    ),
    "simapp5": Generation(
        "simapp5",
        "SimApp v5.3.3, ROS 1 / Gazebo classic (console until 2025, DRfC 5)",
        "simtrace-fit",
        LOOK_SIMAPP5,
        "look: deepracer-simapp v5.3.3 bundle/worlds/reinvent_*.world, models/reinvent_base; car: fitted on the "
        "console 2022 and DRfC simtraces of that SimApp (research/tyre_fit/, leave one file out)",
    ),
    "simapp6": Generation(
        "simapp6",
        "SimApp v6.0.5, ROS 2 / gz-sim (DeepRacer on AWS, DRfC 6)",
        "simapp6-fit",
        LOOK_SIMAPP6,
        "look: deepracer-simapp v6.0.5 bundle/worlds/reinvent_*.world; car: the v6.0.5 files' μ 0.5 wheels and "
        "0.036 m mesh, the rest fitted on DeepRacer on AWS's 2026 logs (research/simapp6_fit/, leave one file out)",
    ),
}
GENERATION_NAMES: tuple[str, ...] = tuple(GENERATIONS)
DEFAULT_GENERATION = "simapp6"
"""What users race in now (DeepRacer on AWS); `python -m benchmarks transfer` judges in `2019`, where its models trained."""


def generation(name: str) -> Generation:
    """The generation called `name`; an unknown name is a ValueError naming RACER_GENERATION and the valid names."""
    try:
        return GENERATIONS[name]
    except KeyError:
        raise ValueError(
            f"RACER_GENERATION: unknown generation {name!r}; choose one of {', '.join(GENERATION_NAMES)}"
        ) from None
