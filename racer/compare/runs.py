"""One run as `racer compare` needs it, read with the viewer's RunReader: the same curves, evaluations and best lap
the viewer shows (racer.viewer.run_reader), so a layout it learns to read is compared too, and its settings
(racer.compare.settings)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from racer.analysis.run_line import LineBook
from racer.compare.settings import RunSettings, read_run_settings
from racer.viewer.lap_bound import best_lap_bound
from racer.viewer.run_reader import RunLocation, RunReader, resolve_run


@dataclass(frozen=True)
class ComparedRun:
    label: str
    """The name the page shows: the model prefix's last part, numbered when two runs share it."""
    target: str
    """As given on the command line."""
    source: str
    """Where it was read: the prefix and the store."""
    iterations: tuple[dict, ...]
    """Per-iteration summaries (racer's iterations log, or built from TrainingMetrics.json)."""
    evaluations: tuple[dict, ...]
    """Worker 0's greedy evaluation of each checkpoint."""
    best_lap: dict | None
    evaluation_runs: tuple[dict, ...]
    """`racer evaluate` runs of the model."""
    track: dict | None
    settings: RunSettings
    finished: bool
    notes: tuple[str, ...]
    bound: dict | None = None
    """The best lap against its car's lap-time bound (racer.compare.bound); None: not asked for."""

    @property
    def episodes(self) -> int:
        return sum(int(r.get("episodes") or 0) for r in self.iterations)

    def training_minutes(self) -> list[float | None]:
        """Wall time of training at the end of each iteration, in minutes; None where the run's files hold no wall
        time (runs racer did not train). A resumed run's trainer clock starts again at 0: its segments are
        added up, so the axis keeps going forward (the time the run stood still is not counted)."""
        minutes: list[float | None] = []
        offset_s = previous_s = 0.0
        for record in self.iterations:
            elapsed_s = record.get("elapsed_s")
            if elapsed_s is None:
                minutes.append(None)
                continue
            if elapsed_s < previous_s:
                offset_s += previous_s
            previous_s = float(elapsed_s)
            minutes.append((offset_s + previous_s) / 60)
        return minutes


def _short_name(location: RunLocation) -> str:
    return location.prefix.rstrip("/").rsplit("/", 1)[-1] or location.prefix


def read_run(location: RunLocation, target: str, label: str, lines: LineBook | None = None) -> ComparedRun:
    reader = RunReader(location)
    progress = reader.progress()
    iterations = tuple(progress["iterations"])
    last_progress = next((r["progress"] for r in reversed(iterations) if isinstance(r.get("progress"), dict)), None)
    settings = read_run_settings(location.store, location.prefix, reader.worker_params(), last_progress)
    notes = ([progress["note"]] if progress.get("note") else []) + list(settings.notes)
    if not iterations:
        notes.append("no training iterations in its files (no metrics/iterations.jsonl or TrainingMetrics.json)")
    return ComparedRun(
        label=label,
        target=target,
        source=location.describe(),
        iterations=iterations,
        evaluations=tuple(progress["evaluations"]),
        best_lap=progress["best_lap"],
        evaluation_runs=tuple(progress["evaluation_runs"]),
        track=reader.track(),
        settings=settings,
        finished=bool(progress["finished"]),
        notes=tuple(notes),
        bound=None if lines is None else best_lap_bound(reader, progress["best_lap"], lines),
    )


def load_runs(targets: Sequence[str], lines: LineBook | None = None) -> list[ComparedRun]:
    """The runs the targets name (a model folder, s3://bucket/MODEL or a model prefix in RACER_STORE, as `racer
    view` takes them: `resolve_run`, which raises RunNotFoundError naming a target that is not a run), labelled by
    their names; a name two runs share gets ` (1)`, ` (2)` ...; `lines`: the best laps' lap-time bounds come from it
    (None: no bound)."""
    locations = [resolve_run(target) for target in targets]
    names = [_short_name(location) for location in locations]
    labels = []
    for index, name in enumerate(names):
        same = names[:index].count(name)
        labels.append(name if names.count(name) == 1 else f"{name} ({same + 1})")
    return [
        read_run(location, target, label, lines)
        for location, target, label in zip(locations, targets, labels, strict=True)
    ]
