"""`racer view`: the web page of a training run, live (with Redis) or finished (from the store alone)."""

from __future__ import annotations

import logging

import click

from racer.shared.config import settings_from_env

DEFAULT_PORT = 8100
"""DeepRacer-for-Cloud's viewer port (DR_WEBVIEWER_PORT), so habits carry over."""


def serve(app, host: str, port: int) -> None:
    import uvicorn

    uvicorn.run(app, host=host, port=port, log_level="warning", access_log=False)


@click.command(name="view")
@click.argument("target")
@click.option(
    "--live",
    is_flag=True,
    help="Also show the workers' camera streams and status from Redis "
    "(RACER_REDIS_URL); TARGET is then the model prefix of the running training in RACER_STORE.",
)
@click.option(
    "--host",
    default="127.0.0.1",
    show_default=True,
    help="Address to listen on. The default is reachable from this machine only.",
)
@click.option("--port", type=click.IntRange(1, 65535), default=DEFAULT_PORT, show_default=True)
def view_command(target: str, live: bool, host: str, port: int) -> None:
    """Open a run in the browser: TARGET is a model folder (racer-data/MODEL), s3://bucket/MODEL or a model prefix,
    or a finished race's folder (`racer race --out`, default races/<race>): its leaderboard with playable videos.

    Without --live it reads only the store: curves, evaluations, the best lap, `racer evaluate` laps and videos.
    Either way the page lists the store's other runs and lays a ticked run's curves over the shown one's.
    """
    from pathlib import Path

    from racer.analysis.run_line import LineBook
    from racer.viewer.app import create_app
    from racer.viewer.live import LiveRun
    from racer.viewer.race_app import create_race_app, is_race_folder
    from racer.viewer.run_reader import RunLocation, RunNotFoundError, RunReader, resolve_run

    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(levelname)s viewer: %(message)s")
    race_folder = Path(target).expanduser()
    if is_race_folder(race_folder):
        if live:
            raise click.ClickException(f"{target} is a finished race: --live is for a running training")
        shown_host = "localhost" if host in {"127.0.0.1", "::1", "localhost"} else host
        click.echo(f"racer view: race {race_folder.resolve()} at http://{shown_host}:{port}/", err=True)
        serve(create_race_app(race_folder), host, port)
        return
    settings = settings_from_env()
    if live:
        from racer.shared.store import open_store

        location = RunLocation(open_store(settings.store), target.strip("/"))
        live_run = LiveRun(settings.redis, location.prefix)
    else:
        try:
            location = resolve_run(target)
        except RunNotFoundError as error:
            raise click.ClickException(str(error)) from error
        live_run = None
    app = create_app(RunReader(location, lines=LineBook()), live_run)
    shown_host = "localhost" if host in {"127.0.0.1", "::1", "localhost"} else host
    click.echo(f"racer view: {location.describe()}{' (live)' if live else ''} at http://{shown_host}:{port}/", err=True)
    serve(app, host, port)
