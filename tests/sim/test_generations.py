"""A generation is one choice: its name picks the look and the car; a car profile beside it replaces only the car;
RACER_GENERATION is the commands' default; each generation's look carries its world files' facts."""

from __future__ import annotations

import dataclasses

import click
import numpy as np
import pytest
from click.testing import CliRunner

from racer.options.generation import car_profile_option, generation_option
from racer.shared.config import generation_name
from racer.shared.sim.car.dynamics import CAR_DYNAMICS, DEFAULT_CAR_PROFILE, SIMTRACE_FIT_DYNAMICS
from racer.shared.sim.config import EnvConfig
from racer.shared.sim.generations.catalog import DEFAULT_GENERATION, GENERATION_NAMES, GENERATIONS, generation
from racer.shared.sim.generations.looks import LIGHTING_2019, LOOK_2019, LOOK_SIMAPP6
from racer.shared.sim.scene import world_look
from racer.shared.worker_settings import WorkerSettings


def test_three_generations_the_default_is_simapp6_and_its_car_is_the_default_profile():
    assert GENERATION_NAMES == ("2019", "simapp5", "simapp6") and DEFAULT_GENERATION == "simapp6"
    assert GENERATIONS[DEFAULT_GENERATION].car_profile == DEFAULT_CAR_PROFILE
    for name, chosen in GENERATIONS.items():
        assert chosen.name == name and chosen.car == CAR_DYNAMICS[chosen.car_profile] and chosen.sources
    with pytest.raises(ValueError, match=r"RACER_GENERATION: unknown generation '2020'; choose one of 2019, simapp5"):
        generation("2020")


@pytest.mark.parametrize("name", GENERATION_NAMES)
def test_an_env_config_takes_the_generations_look_and_car_unless_a_car_is_given(name):
    config = EnvConfig(generation=name)
    assert (config.look, config.car_dynamics) == (generation(name).look, generation(name).car)
    replaced = EnvConfig(generation=name, car_dynamics=SIMTRACE_FIT_DYNAMICS)
    assert (replaced.look, replaced.car_dynamics) == (generation(name).look, SIMTRACE_FIT_DYNAMICS)
    assert EnvConfig().generation == DEFAULT_GENERATION
    with pytest.raises(ValueError, match="EnvConfig.generation: RACER_GENERATION: unknown generation"):
        EnvConfig(generation="ros3")


def test_worker_settings_car_is_the_generations_unless_a_car_profile_is_named():
    assert WorkerSettings(generation="2019").car_dynamics == generation("2019").car
    assert WorkerSettings(generation="2019", car_profile="simtrace-fit").car_dynamics == SIMTRACE_FIT_DYNAMICS
    params = WorkerSettings(generation="simapp5").to_training_params("model", 1)
    assert (params["RACER_GENERATION"], params["RACER_CAR_PROFILE"]) == ("simapp5", "")
    read = WorkerSettings.from_training_params({**params, "RACER_GENERATION": ""}, "training_params.yaml")
    assert read.generation == DEFAULT_GENERATION  # an empty value is the default, as DeepRacer's yaml writes it
    with pytest.raises(ValueError, match=r"training_params.yaml: RACER_GENERATION: unknown generation 'gazebo'"):
        WorkerSettings.from_training_params({**params, "RACER_GENERATION": "gazebo"}, "training_params.yaml")


def test_racer_generation_is_the_options_default_and_the_option_wins():
    assert generation_name({}) is None and generation_name({"RACER_GENERATION": " 2019 "}) == "2019"

    @click.command()
    @generation_option
    @car_profile_option
    def show(generation, car_profile):
        click.echo(f"{generation}|{car_profile}")

    runner = CliRunner()
    assert runner.invoke(show, [], env={"RACER_GENERATION": ""}).output.strip() == f"{DEFAULT_GENERATION}|"
    assert runner.invoke(show, [], env={"RACER_GENERATION": "2019"}).output.strip() == "2019|"
    chosen = runner.invoke(
        show, ["--generation", "simapp5", "--car-profile", "gazebo"], env={"RACER_GENERATION": "2019"}
    )
    assert chosen.output.strip() == "simapp5|gazebo"
    bad = runner.invoke(show, [], env={"RACER_GENERATION": "ros3"})
    assert bad.exit_code == 2 and "'ros3' is not one of '2019', 'simapp5', 'simapp6'" in bad.output
    assert "--car-profile replaces its car" in " ".join(runner.invoke(show, ["--help"]).output.split())


def test_the_2019_look_has_walls_dae_walls_no_sky_and_its_lights():
    """deepracer-core 6d9f8481: the base world's 2 m walls 0.3 m out with the walls.jpg gradient (carpet's), no sky in
    any world, a point light of 0.9; today's base world keeps its 1 m walls 0.91 m out."""
    carpet = world_look.LOOKS["carpet"]
    base_2019 = LOOK_2019.world_look("reinvent_base", "base")
    assert (base_2019.wall_height_m, base_2019.field_margin_m) == (2.0, 0.3)
    assert (base_2019.wall_bottom_rgb, base_2019.wall_top_rgb) == (carpet.wall_bottom_rgb, carpet.wall_top_rgb)
    assert base_2019.road_rgb == world_look.LOOKS["base"].road_rgb  # the floors keep their calibrated colours
    assert LOOK_2019.world_look("reinvent_base", "carpet").background_rgb == (0, 0, 0)
    assert LOOK_SIMAPP6.world_look("reinvent_base", "base") is world_look.LOOKS["base"]
    assert LOOK_SIMAPP6.world_look("reinvent_base", "carpet") is carpet
    assert LIGHTING_2019.point_diffuse == 0.9 and LOOK_SIMAPP6.lighting.point_diffuse == 0.225


def test_each_lighting_gives_the_floor_the_same_mean_light_and_a_gain_scales_only_the_drawn_lights():
    """The textures keep their calibration in every generation: the floor at the reference point gets the SimApp
    v6.0.5 lights' mean; the 2019 point light then takes a larger share of it, and the walls less."""
    reference = world_look.floor_light()
    for chosen in GENERATIONS.values():
        floor = world_look.floor_light(lighting=chosen.look.lighting)
        assert float(np.mean(floor)) == pytest.approx(float(np.mean(reference)), rel=1e-9)
    brighter = LOOK_2019.with_light_factor(1.15)
    assert brighter.lighting.render_scale == pytest.approx(1.15 * LIGHTING_2019.render_scale)
    assert np.allclose(
        world_look.floor_light(lighting=brighter.lighting), world_look.floor_light(lighting=LIGHTING_2019)
    )
    assert dataclasses.replace(brighter, lighting=LIGHTING_2019, name="2019") == LOOK_2019
