"""The compare page: one self-contained HTML file (racer.analysis.report, pictures embedded) with the runs side by
side: an overview, the settings that differ (all of them at a tick), training curves on shared axes, each
checkpoint's evaluation and the best laps. The compared figures are embedded too, as JSON (`<script id="compare-data">`),
for whoever wants them without reading the pictures."""

from __future__ import annotations

import html
import json
import math
import tempfile
from collections.abc import Sequence
from pathlib import Path

from racer.analysis.report import Report, write_html
from racer.compare import plots
from racer.compare.runs import ComparedRun
from racer.compare.settings import settings_table
from racer.shared.run_progress import clock

STYLE = """
td.run, th.run { text-align: left; white-space: nowrap; }
td.text { text-align: left; max-width: 22em; }
.swatch { display: inline-block; width: 0.9em; height: 0.9em; border-radius: 2px; margin-right: 0.4em;
          vertical-align: -0.1em; }
table.settings td { text-align: left; max-width: 36em; overflow-wrap: anywhere; }
table.settings tr.differs td { background: #ffe9a8; font-weight: 600; }
table.settings tr.differs td:first-child { border-left: 4px solid #e0a000; }
table.settings td.absent { color: #999; font-style: italic; }
table.settings tr.same { display: none; }
body:has(#all-settings:checked) table.settings tr.same { display: table-row; }
td.best { background: #e6f4ea; }
details { margin: 0.4em 0; } pre { background: #f6f6f6; padding: 0.6em; overflow-x: auto; font-size: 12px; }
label.toggle { font-size: 14px; color: #444; }
"""

RECENT_ITERATIONS = 5
"""The overview's "last" reward and progress average this many iterations: one iteration's mean is noisy."""


def _swatch(index: int) -> str:
    return f"<span class='swatch' style='background:{plots.run_colour(index)}'></span>"


def _run_cell(index: int, run: ComparedRun) -> str:
    return f"<td class='run'>{_swatch(index)}{html.escape(run.label)}</td>"


def _table(head: Sequence[str], rows: Sequence[str], css_class: str = "") -> str:
    heading = "".join(f"<th>{html.escape(h)}</th>" for h in head)
    attribute = f" class='{css_class}'" if css_class else ""
    return f"<table{attribute}><thead><tr>{heading}</tr></thead><tbody>{''.join(rows)}</tbody></table>"


def _fmt(value, digits: int = 1, unit: str = "") -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "–"
    return f"{value:.{digits}f}{unit}"


def _recent_mean(run: ComparedRun, key: str) -> float | None:
    values = [r[key] for r in run.iterations[-RECENT_ITERATIONS:] if r.get(key) is not None]
    return sum(values) / len(values) if values else None


def overview(runs: Sequence[ComparedRun]) -> str:
    rows = []
    for index, run in enumerate(runs):
        minutes = [m for m in run.training_minutes() if m is not None]
        evaluations = [e for e in run.evaluations if e.get("trials")]
        best_evaluation = max(evaluations, key=lambda e: e["mean_progress"], default=None)
        laps = [e["best_lap_time_s"] for e in evaluations if e.get("best_lap_time_s")]
        cells = [
            _run_cell(index, run),
            f"<td class='text'>{html.escape(run.source)}</td>",
            f"<td>{len(run.iterations)}</td>",
            f"<td>{run.episodes}</td>",
            f"<td>{clock(60 * minutes[-1]) if minutes else '–'}</td>",
            f"<td>{_fmt(_recent_mean(run, 'mean_reward'))}</td>",
            f"<td>{_fmt(_recent_mean(run, 'mean_progress'), 1, ' %')}</td>",
            f"<td>{_fmt(best_evaluation and best_evaluation['mean_progress'], 1, ' %')}</td>",
            f"<td>{_fmt(min(laps) if laps else None, 3, ' s')}</td>",
            f"<td class='text'>{html.escape(plots.best_lap_text(run.best_lap))}</td>",
            f"<td>{'finished' if run.finished else 'not finished'}</td>",
        ]
        rows.append(f"<tr>{''.join(cells)}</tr>")
    head = [
        "run",
        "where",
        "iterations",
        "episodes",
        "training time",
        f"reward (last {RECENT_ITERATIONS})",
        f"progress (last {RECENT_ITERATIONS})",
        "best evaluation progress",
        "best evaluation lap",
        "best lap in the simtraces",
        "state",
    ]
    return _table(head, rows)


def evaluation_table(runs: Sequence[ComparedRun]) -> str:
    """One row per checkpoint, one column per run: laps/trials, mean progress, best lap; ★ the run's best."""
    by_run = [{e["checkpoint_number"]: e for e in run.evaluations} for run in runs]
    numbers = sorted({n for evaluations in by_run for n in evaluations})
    rows = []
    for number in numbers:
        cells = [f"<td>{number}</td>"]
        for evaluations in by_run:
            e = evaluations.get(number)
            if e is None:
                cells.append("<td>–</td>")
                continue
            text = f"{e['laps_completed']}/{e['trials']} laps · {_fmt(e['mean_progress'], 1, ' %')}"
            if e.get("best_lap_time_s"):
                text += f" · {_fmt(e['best_lap_time_s'], 3, ' s')}"
            star = " ★" if e.get("is_best") else ""
            cells.append(f"<td{' class=best' if star else ''}>{html.escape(text)}{star}</td>")
        rows.append(f"<tr>{''.join(cells)}</tr>")
    head_cells = "".join(f"<th class='run'>{_swatch(i)}{html.escape(run.label)}</th>" for i, run in enumerate(runs))
    if not rows:
        return "<p>No checkpoint evaluation in these runs.</p>"
    table = f"<table><thead><tr><th>checkpoint</th>{head_cells}</tr></thead><tbody>{''.join(rows)}</tbody></table>"
    return f"<details><summary>The evaluations as a table ({len(rows)} checkpoints)</summary>{table}</details>"


def best_lap_table(runs: Sequence[ComparedRun]) -> str:
    rows = []
    for index, run in enumerate(runs):
        best = run.best_lap or {}
        evaluated = [e["best_lap_time_s"] for e in run.evaluation_runs if e.get("best_lap_time_s")]
        cells = [
            _run_cell(index, run),
            f"<td>{_fmt(best.get('lap_time_s'), 3, ' s')}</td>",
            f"<td>{_fmt(best.get('progress'), 1, ' %')}</td>",
            f"<td class='run'>{html.escape(plots.best_lap_text(run.best_lap))}</td>",
            f"<td>{best.get('steps', '–')}</td>",
            f"<td>{_fmt(min(evaluated) if evaluated else None, 3, ' s')}</td>",
            *_bound_cells(run.bound),
        ]
        rows.append(f"<tr>{''.join(cells)}</tr>")
    head = ["run", "best lap", "progress", "where", "steps", "best racer evaluate lap"]
    if any(run.bound is not None for run in runs):
        head += ["ratio to the lap-time bound", "bound (flying lap)"]
    return _table(head, rows)


def _bound_cells(bound: dict | None) -> list[str]:
    """The best lap over its car's flying-lap bound and the bound's line, or why there is none."""
    if bound is None:
        return []
    if "ratio" not in bound:
        return ["<td>–</td>", f"<td class='text'>{html.escape(bound['note'])}</td>"]
    return [
        f"<td>{bound['ratio']:.3f}</td>",
        f"<td class='text'>{bound['line_lap_s']:.3f} s · {html.escape(bound['line'])}</td>",
    ]


def settings_section(runs: Sequence[ComparedRun]) -> tuple[str, str]:
    """The settings table and its caption: the rows that differ, marked; the others shown at a tick."""
    table = settings_table([run.settings.values for run in runs])
    differing = [row for row in table if row.differs]
    rows = []
    for row in table:
        cells = [f"<td>{html.escape(row.name)}</td>"]
        for value in row.values:
            if value is None:
                cells.append("<td class='absent'>not set</td>")
            else:
                cells.append(f"<td>{html.escape(value)}</td>")
        rows.append(f"<tr class='{'differs' if row.differs else 'same'}'>{''.join(cells)}</tr>")
    head_cells = "".join(f"<th class='run'>{_swatch(i)}{html.escape(run.label)}</th>" for i, run in enumerate(runs))
    toggle = (
        f"<p><label class='toggle'><input type='checkbox' id='all-settings'> show all {len(table)} settings, "
        "not only those that differ</label></p>"
    )
    body = (
        f"{toggle}<table class='settings'><thead><tr><th>setting</th>{head_cells}</tr></thead>"
        f"<tbody>{''.join(rows)}</tbody></table>"
    )
    names = ", ".join(row.name for row in differing[:12]) + (" …" if len(differing) > 12 else "")
    caption = (
        f"{len(differing)} of {len(table)} settings differ: {names}."
        if differing
        else f"All {len(table)} settings are the same."
    ) + " Keys that only say where a run keeps its files (prefix, bucket, metrics keys) are left out."
    return body, caption


def reward_functions(runs: Sequence[ComparedRun]) -> str:
    parts = []
    for index, run in enumerate(runs):
        code = run.settings.reward_function
        summary = f"{_swatch(index)}{html.escape(run.label)}"
        if code is None:
            parts.append(f"<p>{summary}: no reward_function.py in its folder.</p>")
        else:
            parts.append(f"<details><summary>{summary}</summary><pre>{html.escape(code)}</pre></details>")
    return "".join(parts)


def data_script(runs: Sequence[ComparedRun]) -> str:
    """The compared figures as JSON (`</` escaped so no file content can end the script element)."""
    data = [
        {
            "label": run.label,
            "source": run.source,
            "finished": run.finished,
            "iterations": [
                {
                    key: r.get(key)
                    for key in ("iteration", "episodes", "mean_reward", "mean_progress", "completion_rate")
                }
                | {"training_minutes": minutes}
                for r, minutes in zip(run.iterations, run.training_minutes(), strict=True)
            ],
            "evaluations": list(run.evaluations),
            "best_lap": None if run.best_lap is None else {k: v for k, v in run.best_lap.items() if k != "path"},
            "settings": dict(run.settings.values),
        }
        for run in runs
    ]
    text = json.dumps({"runs": data}).replace("</", "<\\/")
    return f"<script type='application/json' id='compare-data'>{text}</script>"


def write_compare_page(runs: Sequence[ComparedRun], path: Path) -> Path:
    """compare.html for `runs`; the pictures are drawn in a temporary folder and embedded."""
    report = Report(
        title="racer compare: " + " vs ".join(run.label for run in runs),
        source="; ".join(f"{run.label}: {run.source}" for run in runs),
        notes=[f"{run.label}: {note}" for run in runs for note in run.notes],
        style=STYLE,
    )
    body, caption = settings_section(runs)
    with tempfile.TemporaryDirectory(prefix="racer-compare-") as folder:
        pictures = Path(folder)
        report.add_html("Runs", overview(runs))
        report.add_html("Settings", body, caption)
        report.add_picture(
            "Training",
            plots.training_curves(runs, pictures / "training.png"),
            "Mean reward and progress of each iteration's training episodes, by iteration (left) and by wall time "
            f"of training (right); from {plots.SMOOTH_FROM} iterations on, faint: each iteration, bold: the moving "
            "mean over a tenth of the run.",
        )
        if any(run.evaluations for run in runs):
            report.add_picture(
                "Evaluation per checkpoint",
                plots.evaluation_curves(runs, pictures / "evaluations.png"),
                "Worker 0's greedy trials of each checkpoint (DeepRacer's in-training evaluation); ★ the checkpoint "
                "the run chose as its best.",
            )
        report.add_html("", evaluation_table(runs))
        report.add_picture(
            "Best lap",
            plots.best_laps(runs, pictures / "best_laps.png"),
            "The fastest complete lap in each run's simtraces (training and racer evaluate), else the episode "
            "that got furthest; green dot: its start.",
        )
        report.add_html("", best_lap_table(runs))
        report.add_html("Reward functions", reward_functions(runs))
        report.add_html("", data_script(runs))
        return write_html(report, path)
