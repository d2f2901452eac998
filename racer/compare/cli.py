"""`racer compare RUN RUN...`: the runs side by side on one HTML page (racer.compare.page)."""

from __future__ import annotations

import re
from pathlib import Path

import click

MAX_NAME_CHARS = 100


def default_out(labels: list[str]) -> Path:
    """`compare/<run>-vs-<run>.html`, the names made safe for a file name."""
    name = re.sub(r"[^A-Za-z0-9._-]+", "_", "-vs-".join(labels))[:MAX_NAME_CHARS] or "runs"
    return Path("compare") / f"{name}.html"


@click.command("compare")
@click.argument("runs", nargs=-1, required=True)
@click.option(
    "--out",
    type=click.Path(dir_okay=False, path_type=Path),
    help="The page to write [default: ./compare/<run>-vs-<run>.html].",
)
@click.option(
    "--no-line",
    is_flag=True,
    help="Leave out each best lap's ratio to its car's lap-time bound (a racing line takes tens of seconds to compute "
    "on a big track).",
)
def compare_command(runs: tuple[str, ...], out: Path | None, no_line: bool) -> None:
    """Compare training runs on one page: RUN is a model folder (racer-data/MODEL), s3://bucket/MODEL or a model
    prefix in RACER_STORE, as `racer view` takes it; runs of different stores mix.

    The page (one HTML file, pictures embedded) shows training reward and progress per iteration on shared axes,
    by iteration and by wall time, each checkpoint's evaluation, the best laps (with their ratio to the car's
    lap-time bound where the run's track, car and world are known), and every run's settings with the ones that
    differ marked.
    """
    from racer.analysis.run_line import LineBook
    from racer.compare.page import write_compare_page
    from racer.compare.runs import load_runs
    from racer.shared.deepracer.metrics import MetricsError
    from racer.shared.store import StoreError
    from racer.viewer.run_reader import RunNotFoundError

    if len(runs) < 2:
        raise click.UsageError("give at least two runs to compare")
    try:
        compared = load_runs(list(runs), lines=None if no_line else LineBook())
    except (RunNotFoundError, StoreError, MetricsError) as error:
        raise click.ClickException(str(error)) from error
    path = out or default_out([run.label for run in compared])
    path.parent.mkdir(parents=True, exist_ok=True)
    write_compare_page(compared, path)
    for run in compared:
        click.echo(f"{run.label}: {len(run.iterations)} iterations, {run.episodes} episodes ({run.source})")
        for note in run.notes:
            click.secho(f"  note: {note}", fg="yellow")
    click.echo(f"page: {path}")
