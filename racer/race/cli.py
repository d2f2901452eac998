"""`racer race RACE.yaml ENTRANT...`: a local race in DeepRacer on AWS's format, and its leaderboard."""

from __future__ import annotations

from pathlib import Path

import click

from racer.options.generation import generation_option
from racer.options.race import race_workers_option
from racer.options.training import seed_option


@click.command(name="race")
@click.argument("race_file", type=click.Path(dir_okay=False, path_type=Path))
@click.argument("entrants", nargs=-1, required=True)
@race_workers_option
@seed_option
@click.option(
    "--out",
    "out_dir",
    type=click.Path(file_okay=False, path_type=Path),
    default=None,
    help="Where the leaderboard, videos and each entrant's evaluation go. Default: ./races/<race name>.",
)
@click.option("--video/--no-video", default=True, show_default=True, help="In-car, top-view and follow videos.")
@generation_option
def race_command(race_file: Path, entrants: tuple[str, ...], workers, seed, out_dir, video, generation) -> None:
    """Race ENTRANTs on the race RACE_FILE defines and write leaderboard.json, .csv and .html.

    RACE_FILE: DeepRacer on AWS's leaderboard definition (trackConfig, raceType, timingMethod,
    resettingBehaviorConfig, submissionTerminationConditions, maxResets, objectAvoidanceConfig) in YAML or JSON.
    Every entrant races in --generation, --seed seeding its evaluation.
    ENTRANT: [NAME=]SOURCE, SOURCE a model prefix in the store (RACER_STORE) or anything `racer model import`
    takes (a folder, .tar.gz, .zip, s3://bucket/prefix); imports go under races/<race>/<NAME> in the store.
    A broken entrant gets a row with its reason; the others race. HEAD_TO_MODEL and F1 put every entrant on the
    track at once (one multi-car evaluation; --workers does not apply): F1 ranks by finishing order over
    maximumLaps laps, HEAD_TO_MODEL by the timing method on each car's laps.
    """
    from racer.race.entrant_evaluation import resolve_route
    from racer.race.entrants import EntrantError, parse_entrants
    from racer.race.html_report import write_html
    from racer.race.leaderboard import board_json, format_board, standings_from_results, write_board
    from racer.race.race_file import RaceFileError, read_race_file
    from racer.race.runner import race_workers_for_the_cores, run_multi_car_race, run_race
    from racer.race.videos import race_videos
    from racer.shared.config import settings_from_env
    from racer.shared.store import open_store

    try:
        definition = read_race_file(race_file)
        route = resolve_route(definition)
        store = open_store(settings_from_env().store)
        field = parse_entrants(entrants, store, definition.name)
    except (RaceFileError, EntrantError) as error:
        raise click.ClickException(str(error)) from None
    out = (out_dir or Path("races") / definition.name).resolve()
    count = 1 if definition.multi_car else min(workers or race_workers_for_the_cores(), len(field))
    at_once = "all on the track at once" if definition.multi_car else f"{count} at a time"
    ranked_by = "finishing order" if definition.race_type == "F1" else definition.timing_method
    click.echo(
        f"race {definition.name}: {definition.race_type} on {route}, {ranked_by}, "
        f"{len(field)} entrants, {at_once}, seed {seed}, generation {generation} -> {out}"
    )
    if definition.multi_car:
        run = run_multi_car_race(
            definition, field, route=route, out_dir=out, seed=seed, video=video, generation=generation, log=click.echo
        )
    else:
        run = run_race(
            definition,
            field,
            route=route,
            out_dir=out,
            seed=seed,
            workers=count,
            video=video,
            generation=generation,
            log=click.echo,
        )
    standings = standings_from_results(definition, run.results)
    videos = race_videos(out, definition.multi_car)
    paths = write_board(out, definition, route, seed, standings, run.results, videos)
    board = board_json(definition, route, seed, standings, run.results, videos)
    page = write_html(out, definition, board, run.results)
    click.echo("")
    click.echo(format_board(standings, "FINISH_TIME" if definition.race_type == "F1" else definition.timing_method))
    click.echo(f"{len(field)} entrants in {run.wall_s:.1f} s; {paths['json']}, {paths['csv']}, {page}")
    for file_name in videos.values():
        click.echo(f"every car from above: {out / 'videos' / file_name}")
