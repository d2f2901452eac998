"""The `racer` command. Subcommands are imported only when run, so `racer --help` stays fast."""

from __future__ import annotations

import click

from racer.lazy_group import LazyGroup

# name -> (module:attribute of a click command, one-line help). Each module owns its command.
COMMANDS: dict[str, tuple[str, str]] = {
    "train": (
        "racer.local.cli:train_command",
        "Train a model: Redis, store, trainer and N rollout workers as local processes.",
    ),
    "trainer": ("racer.trainer.cli:trainer_command", "Run the PPO trainer process alone (one per training run)."),
    "rollout": ("racer.rollout_worker.cli:rollout_command", "Run one rollout worker (one world) alone."),
    "evaluate": (
        "racer.evaluation_worker.cli:evaluate_command",
        "Evaluate a model: DeepRacer trials or the 4-minute summit rule.",
    ),
    "race": (
        "racer.race.cli:race_command",
        "Race models on a DeepRacer-on-AWS race definition and write a leaderboard.",
    ),
    "analyze": ("racer.analysis.cli:analyze_command", "Analyse simtrace logs into tables, plots and an HTML report."),
    "compare": (
        "racer.compare.cli:compare_command",
        "Compare training runs side by side on one page: curves, evaluations, best laps, settings.",
    ),
    "model": ("racer.model_io.cli:model_group", "Validate, import and export models in DeepRacer's layout."),
    "bench": ("racer.bench_moved:bench_command", "Where the benchmarks went: python -m benchmarks, in a checkout."),
    "track": ("racer.track.cli:track_group", "List, inspect and plot tracks."),
    "reward": ("racer.reward.cli:reward_group", "Test a reward function over a whole track."),
    "recipe": (
        "racer.recipe.cli:recipe_command",
        "Write custom files for a fast lap of one track, made from the car's racing line.",
    ),
    "view": (
        "racer.viewer.cli:view_command",
        "Watch a run in the browser: camera streams, curves, evaluations, best lap.",
    ),
}


@click.group(
    cls=LazyGroup, commands=COMMANDS, context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 120}
)
@click.version_option(package_name="racer-deepracer")
def main() -> None:
    """Train, evaluate and analyse DeepRacer-style models locally (MuJoCo, PyTorch PPO, Redis, S3/MinIO)."""


if __name__ == "__main__":
    main()
