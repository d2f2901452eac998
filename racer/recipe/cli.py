"""`racer recipe NAME --out DIR`: custom files for a fast lap of one track and car, made from its racing line."""

from __future__ import annotations

import json
from pathlib import Path

import click

from racer.options.generation import car_profile_option, generation_option, world_option
from racer.options.track import direction_option
from racer.recipe.folder import Car, RecipeError, check_out, make_recipe, write_recipe
from racer.shared.sim.car.dynamics import car_profile as car_profile_named
from racer.shared.sim.generations.catalog import generation as generation_named
from racer.shared.sim.tracks.track import Track, TrackError


@click.command("recipe")
@click.argument("track", metavar="NAME")
@direction_option
@click.option(
    "--out",
    type=click.Path(path_type=Path),
    required=True,
    help="The folder to write (refused if it exists, unless --force).",
)
@click.option("--force", is_flag=True, help="Replace an existing --out folder.")
@generation_option
@car_profile_option
@world_option()
@click.option(
    "--action-space",
    type=click.Choice(("discrete", "continuous")),
    default="discrete",
    show_default=True,
    help="Discrete: the line's needs clustered into actions; continuous: the bounds of its needs.",
)
def recipe_command(
    track: str, out: Path, force: bool, generation: str, car_profile: str, world: str, action_space: str
) -> None:
    """Write custom files for a fast lap of track NAME (as `racer track show` takes it) with the car of
    --generation / --car-profile: reward_function.py with the racing line pasted in, model_metadata.json with the
    actions the line needs, hyperparameters.json, workers.json and preset.json (docs/racing.md). The line is the car's lap-time
    bound on the track: computing it takes a minute or two."""
    try:
        check_out(out, force)
        route = Track.load(track)
    except (RecipeError, TrackError) as error:
        raise click.ClickException(str(error)) from error
    dynamics = car_profile_named(car_profile) if car_profile else generation_named(generation).car
    car = Car(dynamics=dynamics, generation=generation, car_profile=car_profile, world=world)
    click.echo(f"recipe: the racing line of {car.describe()} on {route.name} ...", err=True)
    try:
        recipe = make_recipe(route, car, action_space, route_name=track)
        write_recipe(recipe, out, force)
    except RecipeError as error:
        raise click.ClickException(str(error)) from error
    click.echo(json.dumps({"track": route.name, "out": str(out), **recipe.summary()}))
