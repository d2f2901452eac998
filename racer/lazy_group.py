"""A click group that imports a subcommand's module only when that subcommand runs, so `--help` stays fast."""

from __future__ import annotations

import importlib
from collections.abc import Mapping

import click


class LazyGroup(click.Group):
    """`commands` maps a name to ("module:attribute" of a click command, one-line help)."""

    def __init__(self, *args, commands: Mapping[str, tuple[str, str]], section: str = "Commands", **kwargs):
        super().__init__(*args, **kwargs)
        self.lazy_commands = dict(commands)
        self.section = section

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted(self.lazy_commands)

    def get_command(self, ctx: click.Context, name: str) -> click.Command | None:
        if name not in self.lazy_commands:
            return None
        module_name, attribute = self.lazy_commands[name][0].split(":")
        return getattr(importlib.import_module(module_name), attribute)

    def format_commands(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        with formatter.section(self.section):
            formatter.write_dl([(name, self.lazy_commands[name][1]) for name in self.list_commands(ctx)])
