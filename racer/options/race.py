"""`racer race --workers`: how many entrants race at once, taken by `racer race` and the race bench that runs it."""

from __future__ import annotations

import click

race_workers_option = click.option(
    "--workers",
    type=click.IntRange(min=1),
    default=None,
    help="Entrants racing at once, one process each. Default: one per core.",
)
