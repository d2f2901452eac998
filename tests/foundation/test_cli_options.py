"""One option per knob: commands that take the same option take it with the same type, range, default and help.

`racer train` hands most of its options on to `racer trainer`; the two once drifted (`--workers` 1..32 in one,
1..64 in the other). Only whether an option is required may differ (`racer trainer` requires `--model-prefix`, and a
required option's default is never used).
"""

from __future__ import annotations

import importlib

import click
import pytest

from racer.local.cli import train_command
from racer.trainer.cli import trainer_command

TYPE_FIELDS = ("choices", "case_sensitive", "min", "max", "min_open", "max_open", "clamp", "exists", "file_okay",
               "dir_okay", "path_type", "resolve_path", "writable", "readable")  # fmt: skip


def facts(option: click.Option) -> dict:
    """What a user meets of an option, `required` and its default aside."""
    kind = option.type
    return {
        "name": option.name,
        "opts": tuple(option.opts),
        "secondary_opts": tuple(option.secondary_opts),
        "type": (
            type(kind).__name__,
            *((field, getattr(kind, field)) for field in TYPE_FIELDS if hasattr(kind, field)),
        ),
        "help": option.help,
        "multiple": option.multiple,
        "is_flag": option.is_flag,
        "count": option.count,
        "hidden": option.hidden,
        "metavar": option.metavar,
        "envvar": option.envvar,
        "nargs": option.nargs,
    }


def options(command: click.Command) -> dict[str, click.Option]:
    return {name: param for param in command.params if isinstance(param, click.Option) for name in param.opts}


def default(option: click.Option):
    """The option's default, None for none (click 8.3+ marks that with a sentinel)."""
    return None if option.default is getattr(click.core, "UNSET", None) else option.default


def disagreements(first: click.Command, second: click.Command, only: str | None = None) -> list[str]:
    """Each option both commands take (or `only` that one), where they differ in more than `required`."""
    mine, theirs = options(first), options(second)
    found = []
    for name in sorted(mine.keys() & theirs.keys() if only is None else {only}):
        a, b = mine[name], theirs[name]
        fa, fb = facts(a) | {"default": default(a)}, facts(b) | {"default": default(b)}
        if a.required != b.required:  # a required option's default is never used, so it must have none
            fa["default"] = default(a) if a.required else None
            fb["default"] = default(b) if b.required else None
        found += [
            f"{name} {key}: {first.name} {fa[key]!r} / {second.name} {fb[key]!r}" for key in fa if fa[key] != fb[key]
        ]
    return found


def test_racer_train_and_racer_trainer_agree_on_every_option_they_share():
    shared = options(train_command).keys() & options(trainer_command).keys()
    assert {"--workers", "--track", "--worlds", "--seed", "--custom-files", "--model-prefix"} <= shared
    assert disagreements(train_command, trainer_command) == []


COMMANDS = {
    "racer train": "racer.local.cli:train_command",
    "racer trainer": "racer.trainer.cli:trainer_command",
    "racer rollout": "racer.rollout_worker.cli:rollout_command",
    "racer evaluate": "racer.evaluation_worker.cli:evaluate_command",
    "racer race": "racer.race.cli:race_command",
    "racer reward test": "racer.reward.cli:test_command",
    "bench race-pace": "benchmarks.race_pace:race_pace_command",
    "bench time-to-lap": "benchmarks.time_to_lap:time_to_lap_command",
    "bench throughput": "benchmarks.throughput:throughput_bench_command",
    "bench race": "benchmarks.race:race_bench_command",
    "bench viewer": "benchmarks.viewer:viewer_bench_command",
    "bench sac": "benchmarks.sac:sac_bench_command",
    "bench ppo": "benchmarks.ppo:ppo_bench_command",
    "bench sim": "benchmarks.sim:sim_bench_command",
    "racer model explain": "racer.model_io.explain:explain_command",
    "bench transfer": "benchmarks.transfer:transfer_bench_command",
}
KNOBS = {
    "--workers": ("racer train", "racer trainer", "bench race-pace", "bench time-to-lap", "bench viewer",
                  "bench transfer"),
    "--envs": ("racer train", "racer rollout", "bench throughput"),
    "--track": ("racer train", "racer trainer", "racer evaluate", "racer reward test", "bench time-to-lap",
                "bench viewer", "bench sim"),
    "--direction": ("racer train", "racer trainer", "racer evaluate", "racer reward test", "bench race-pace",
                    "bench time-to-lap", "bench sim"),
    "--generation": ("racer train", "racer trainer", "racer evaluate", "racer race", "bench race-pace"),
    "--car-profile": ("racer train", "racer trainer", "racer evaluate"),
    "--device": ("racer train", "racer trainer", "bench race-pace", "bench time-to-lap", "bench sac", "bench ppo",
                 "bench throughput"),
    "--precision": ("racer train", "racer trainer", "bench time-to-lap"),
    "--seed": ("racer train", "racer trainer", "racer rollout", "racer evaluate", "racer race", "bench race-pace",
               "bench time-to-lap", "bench throughput", "bench race", "bench sac", "bench ppo", "bench sim",
               "bench transfer"),
    "--model-prefix": ("racer train", "racer trainer", "racer rollout", "racer evaluate"),
    "--max-minutes": ("racer train", "racer trainer"),
    "--race-type": ("racer train", "racer trainer", "racer evaluate"),
    "--checkpoint": ("racer evaluate", "racer model explain"),
}  # fmt: skip
RACE_WORKERS = ("--workers", ("racer race", "bench race"))
"""Each knob and the commands that take it. Other knobs under the same name are not compared with these: `racer
race`'s `--workers` (entrants at once, its own row), `racer rollout`'s `--track`/`--world` (overrides, no default),
the race-pace bench's `--track` and `--custom-files` (re:Invent 2018 and the fast-lap recipe by default), the
throughput bench's `--workers` (one per core), `racer reward test`'s and the time-to-lap bench's `--race-type`
(one race each, no workers.json), the transfer bench's repeatable `--generation`, `--car-profile` and `--world`."""


def command(label: str) -> click.Command:
    module, attribute = COMMANDS[label].split(":")
    return getattr(importlib.import_module(module), attribute)


@pytest.mark.parametrize(("knob", "commands"), [*sorted(KNOBS.items()), RACE_WORKERS], ids=lambda v: str(v)[:24])
def test_every_command_that_takes_a_knob_takes_the_same_option(knob, commands):
    first, *others = commands
    for label in others:
        assert disagreements(command(first), command(label), knob) == [], label
