"""`python -m benchmarks ...`: benchmarks that print one JSON line each (speed goals are measured, not asserted).

A bench here is one a user runs to judge their own model, machine or simulator: one module per bench (`sim`, `ppo`,
`transfer`, `fidelity`, `sac`, `rollout`, `throughput`, `time_to_lap`, `race_pace`, `viewer`, `race`) and their helpers
(`race_pace_laps`, `race_pace_picture`: the race-pace bench's lap figures and its picture; `throughput_modes`: the
throughput bench's runs, one per mode and worker count; `time_shares`: where a training run's wall time went, from
its iterations log; `workdir`: the work folder a bench's training run writes to;
`deepracer_data`: where a bench finds DeepRacer's own files, `--data` or RACER_DEEPRACER_DATA; `sim_loop`,
`sim_race_types`: the simulator bench's step loop and its envs with objects; `real_models`, `transfer_drive`,
`transfer_reverse_check`, `transfer_matrix`, `transfer_robustness`: the transfer bench's models, its drives, its reverse
check, matrix and robustness table; `gazebo_frames`: DeepRacer's reference camera frames and racer's at the same poses;
`precision_agreement`: how far a bf16 update lands from fp32's). Studies that answered a question once live in the
repository's `research/`, which the wheel does not install and nothing here imports.
"""

from __future__ import annotations

import click

from racer.lazy_group import LazyGroup

BENCHMARKS: dict[str, tuple[str, str]] = {
    "sim": (
        "benchmarks.sim:sim_bench_command",
        "Environment steps/s with the front camera vs the raw MuJoCo bound.",
    ),
    "ppo": (
        "benchmarks.ppo:ppo_bench_command",
        "One PPO update: samples/s of the trainer vs a plain fp32 baseline.",
    ),
    "transfer": (
        "benchmarks.transfer:transfer_bench_command",
        "Real DeepRacer checkpoints drive racer closed loop: laps and mean progress from evenly spaced starts.",
    ),
    "fidelity": (
        "benchmarks.fidelity.simtrace_replay:fidelity_bench_command",
        "Open-loop replay of real simtraces: pose error after 1 s and 2 s per speed band.",
    ),
    "sac": (
        "benchmarks.sac:sac_bench_command",
        "SAC gradient steps/s (one step per transition in DeepRacer).",
    ),
    "time-to-lap": (
        "benchmarks.time_to_lap:time_to_lap_command",
        "Minutes from scratch until greedy evaluation completes 3 of 3 laps.",
    ),
    "race-pace": (
        "benchmarks.race_pace:race_pace_command",
        "Best lap and best 3-lap average in --minutes with the fast-lap recipe, against the car's lap-time bound.",
    ),
    "rollout": (
        "benchmarks.rollout:rollout_bench_command",
        "Per-frame inference cost at batch 1/4/8 and one worker's CPU per env step with 1/4/8 envs.",
    ),
    "throughput": (
        "benchmarks.throughput:throughput_bench_command",
        "Strict and overlapped training's end-to-end env steps/s and cpu_busy; experience steps/s vs the raw bound.",
    ),
    "viewer": (
        "benchmarks.viewer:viewer_bench_command",
        "Experience steps/s with one live viewer page open vs none.",
    ),
    "race": (
        "benchmarks.race:race_bench_command",
        "A 12-entrant race's entrants per minute with --workers vs racer evaluate one after another.",
    ),
}


@click.group(
    name="benchmarks",
    cls=LazyGroup,
    commands=BENCHMARKS,
    section="Benchmarks",
    context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 120},
)
def bench_group() -> None:
    """Benchmarks; each prints one JSON line on stdout (progress goes to stderr)."""
