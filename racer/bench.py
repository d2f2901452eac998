"""`racer bench ...`: benchmarks that print one JSON line each (speed goals are measured, not asserted)."""

from __future__ import annotations

import importlib

import click

BENCHMARKS: dict[str, tuple[str, str]] = {
    "sim": ("racer.shared.sim.bench:sim_bench_command", "Environment steps/s with the front camera vs the raw MuJoCo bound."),
    "ppo": ("racer.trainer.bench:ppo_bench_command", "One PPO update: samples/s of the trainer vs a plain fp32 baseline."),
    "time-to-lap": ("racer.local_run:time_to_lap_command", "Minutes from scratch until greedy evaluation completes 3 of 3 laps."),
}


class _LazyBenchGroup(click.Group):
    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted(BENCHMARKS)

    def get_command(self, ctx: click.Context, name: str) -> click.Command | None:
        if name not in BENCHMARKS:
            return None
        module_name, attribute = BENCHMARKS[name][0].split(":")
        return getattr(importlib.import_module(module_name), attribute)

    def format_commands(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        with formatter.section("Benchmarks"):
            formatter.write_dl([(name, BENCHMARKS[name][1]) for name in self.list_commands(ctx)])


@click.group(name="bench", cls=_LazyBenchGroup)
def bench_group() -> None:
    """Benchmarks; each prints one JSON line on stdout (progress goes to stderr)."""
