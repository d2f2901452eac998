"""`racer bench`: the benchmarks left the installed package; this says where they went."""

from __future__ import annotations

import click

MOVED_MESSAGE = (
    "racer's benchmarks are not part of the installed package: from a checkout of the repository, run "
    "`python -m benchmarks NAME [OPTIONS]` in its root (`python -m benchmarks --help` lists them; docs/benchmarks.md)"
)


@click.command(
    name="bench",
    context_settings={"ignore_unknown_options": True, "allow_extra_args": True, "help_option_names": []},
)
@click.argument("words", nargs=-1, type=click.UNPROCESSED)
def bench_command(words: tuple[str, ...]) -> None:
    """Where the benchmarks went (python -m benchmarks, in a checkout)."""
    raise click.ClickException(MOVED_MESSAGE)
