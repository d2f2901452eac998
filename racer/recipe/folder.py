"""A recipe folder from a track and a car: the line (the lap-time bound's), its needs, and the four custom files.

* `reward_function.py`: the line pasted in (`reward_source`);
* `model_metadata.json`: the fast-lap recipe's sensor, network and algorithm (racer/defaults/racing) with the action
  space the line needs (`action_space`);
* `hyperparameters.json`: the fast-lap recipe's, unchanged (docs/racing.md gives their reasons);
* `workers.json`: the route, the car, and the worlds where the line holds: every worker drives a world whose tyre μ
  is at least the line's world's, the line's own first (worker 0 evaluates there);
* `preset.json`: `anneal_lr`, the learning rate falling to 0 at the run's limit (racer.trainer.lr_anneal), so the
  run's last checkpoints settle where a race takes the last one.
"""

from __future__ import annotations

import json
import shutil
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from racer.defaults import FAST_LAP_CUSTOM_FILES
from racer.racing_line import CarLimits, LapTimeBoundError, RacingLine, racing_line
from racer.recipe.action_space import continuous_space, discrete_space
from racer.recipe.line_needs import LineNeeds, line_needs
from racer.recipe.reward_source import reward_source
from racer.shared.sim.car.dynamics import CarDynamics
from racer.shared.sim.scene.worlds import WORLD_NAMES, get_world
from racer.shared.sim.tracks.track import Track

RECIPE_FILES = ("reward_function.py", "model_metadata.json", "hyperparameters.json", "workers.json", "preset.json")
RECIPE_PRESET = {"anneal_lr": True}
MAX_WORKERS = 32
"""`racer train --workers`' largest: workers.json names a world for each worker a run can have."""
CLEARANCE_TOLERANCE_M = 0.01
"""A line whose car comes closer to a border than this beyond the bound's margin did not converge on the road."""
CURVATURE_TOLERANCE = 1.05
"""A line turning tighter than this × the car's tightest turn did not converge within the steering limit."""


class RecipeError(ValueError):
    """No recipe for this track and car; the message names the track and what failed."""


@dataclass(frozen=True)
class Car:
    """The car a recipe is for: its dynamics, the names it was asked by, the world the line is computed in."""

    dynamics: CarDynamics
    generation: str
    car_profile: str
    """"" for the generation's car."""
    world: str

    def describe(self) -> str:
        profile = self.car_profile or "its car"
        return f"the {self.generation} generation, {profile}, {self.world} world"


@dataclass(frozen=True)
class Recipe:
    line: RacingLine
    needs: LineNeeds
    files: dict[str, str]
    """File name -> text."""

    def summary(self) -> dict:
        return {
            "bound": self.line.summary(),
            "held_flying_lap_s": round(self.needs.lap_s, 3),
            "held_lateral_accel_mps2": round(self.needs.held.lateral_accel_mps2, 3),
            "command_lead_s": round(self.needs.command_lead_s, 3),
            "stations_beyond_lock": self.needs.over_lock_stations,
            "action_space": json.loads(self.files["model_metadata.json"])["action_space"],
        }


def make_recipe(
    route: Track,
    car: Car,
    action_space: str = "discrete",
    route_name: str | None = None,
    control_spacings_m: tuple[float, ...] | None = None,
) -> Recipe:
    """The recipe for `route` and `car`. `route_name`: what workers.json names the route by (default its name);
    `control_spacings_m`: the bound's optimiser stages (default the bound's; tests pass a coarse one)."""
    limits = CarLimits.of_car(car.dynamics, world=car.world)
    stages = {} if control_spacings_m is None else {"control_spacings_m": control_spacings_m}
    try:
        line = racing_line(route, limits, **stages)
    except LapTimeBoundError as error:
        raise RecipeError(f"no recipe for track {route.name}: {error}") from error
    return recipe_from_line(route, car, line, action_space, route_name)


def recipe_from_line(
    route: Track, car: Car, line: RacingLine, action_space: str = "discrete", route_name: str | None = None
) -> Recipe:
    """The recipe of `line`, the racing line of `car` on `route` (`make_recipe` computes it)."""
    _check_converged(route, line)
    needs = line_needs(line, car.dynamics)
    metadata = json.loads((FAST_LAP_CUSTOM_FILES[action_space] / "model_metadata.json").read_text())
    if action_space == "discrete":
        metadata["action_space"] = discrete_space(needs, car.dynamics).to_json()
    else:
        metadata["action_space"] = continuous_space(needs)
    files = {
        "reward_function.py": reward_source(route, needs, car.describe()),
        "model_metadata.json": json.dumps(metadata, indent=4) + "\n",
        "hyperparameters.json": (FAST_LAP_CUSTOM_FILES[action_space] / "hyperparameters.json").read_text(),
        "workers.json": json.dumps(_workers(route_name or route.name, car), indent=4) + "\n",
        "preset.json": json.dumps(RECIPE_PRESET, indent=4) + "\n",
    }
    return Recipe(line, needs, files)


def write_recipe(recipe: Recipe, out: Path, force: bool = False) -> None:
    """Write the recipe's files into `out`, a new folder (an existing one only with `force`: it is replaced)."""
    check_out(out, force)
    if out.exists():
        shutil.rmtree(out) if out.is_dir() else out.unlink()
    out.mkdir(parents=True)
    for name, text in recipe.files.items():
        (out / name).write_text(text)


def check_out(out: Path, force: bool) -> None:
    """Refuse an existing `out` without `force` (before the line is computed, which takes a while)."""
    if out.exists() and not force:
        raise RecipeError(f"{out} exists: give another --out, or --force to replace it")


def _check_converged(route: Track, line: RacingLine) -> None:
    if not np.all(np.isfinite(line.speeds_mps)) or not np.isfinite(line.lap_time_s):
        raise RecipeError(f"no recipe for track {route.name}: the racing line's speed profile is not finite")
    if line.min_clearance_m < -CLEARANCE_TOLERANCE_M:
        raise RecipeError(
            f"no recipe for track {route.name}: the racing line did not converge on the road (the car's side "
            f"{-line.min_clearance_m:.3f} m beyond a border)"
        )
    if line.max_curvature_per_m > CURVATURE_TOLERANCE * line.limits.max_curvature_per_m:
        raise RecipeError(
            f"no recipe for track {route.name}: the racing line did not converge within the steering limit "
            f"(curvature {line.max_curvature_per_m:.2f} /m, the car turns at most "
            f"{line.limits.max_curvature_per_m:.2f} /m)"
        )


def _workers(route_name: str, car: Car) -> dict:
    """workers.json: the route and the car for every worker, and the worlds the line holds in, in turn."""
    own_mu = get_world(car.world).tyre_friction
    holding = [car.world] + [w for w in WORLD_NAMES if w != car.world and get_world(w).tyre_friction >= own_mu]
    return {
        "WORLD_NAME": route_name,
        "RACER_GENERATION": car.generation,
        "RACER_CAR_PROFILE": car.car_profile,
        "workers": [{"RACER_WORLD": holding[i % len(holding)]} for i in range(MAX_WORKERS)],
    }
