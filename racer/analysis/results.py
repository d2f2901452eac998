"""`Analysis`: the tables of one run and what was made of them (pictures, CSV files, the report), and the row
selections the track pictures and the reward what-if use."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import pandas as pd

from racer.analysis.obstacle_layout import ObstacleLayout
from racer.analysis.sources import TRAINING, SimtraceFiles
from racer.analysis.track_sections import Track

if TYPE_CHECKING:
    from racer.analysis.line_analysis import LineComparison


@dataclass
class Analysis:
    files: SimtraceFiles
    steps: pd.DataFrame
    episodes: pd.DataFrame
    iterations: pd.DataFrame
    iterations_by_worker: pd.DataFrame
    workers: pd.DataFrame
    evaluation_laps: pd.DataFrame
    evaluations: pd.DataFrame
    track: Track | None
    notes: list[str] = field(default_factory=list)
    pictures: dict[str, Path] = field(default_factory=dict)
    tables_written: dict[str, Path] = field(default_factory=dict)
    report_path: Path | None = None
    reward_comparison: pd.DataFrame | None = None
    reversed_episodes: pd.Series | None = None
    """Per episode, whether it was driven on the reversed route (only known with a track)."""
    track_workers: set[int] | None = None
    """Training workers that drove `track` (None = all of them)."""
    metrics_iterations: pd.DataFrame | None = None
    """Per iteration from TrainingMetrics JSON (training and in-training evaluation), when the source has it."""
    picture_iterations: tuple[int, int | None] | None = None
    """(first, last or None = to the end): training iterations the track pictures and the what-if use."""
    layout: ObstacleLayout = field(default_factory=ObstacleLayout)
    """Race type and fixed obstacles from the run's params yaml (drawn on the track maps)."""
    line_comparison: LineComparison | None = None
    """The evaluation laps against their runs' racing lines (racer.analysis.line_analysis), when compared."""

    @property
    def has_crashes(self) -> bool:
        return bool((self.steps["episode_status"] == "crashed").any())


def on_track(table: pd.DataFrame, track_workers: set[int] | None) -> pd.DataFrame:
    """Rows (steps or episodes) driven on the analysis track: evaluations, and training workers on that track."""
    if track_workers is None:
        return table
    return table[(table["phase"] != TRAINING) | table["worker"].isin(track_workers)]


def for_pictures(table: pd.DataFrame, analysis: Analysis) -> pd.DataFrame:
    """Rows the track pictures and the reward what-if use: on the track, and in the chosen training iterations."""
    table = on_track(table, analysis.track_workers)
    if analysis.picture_iterations is None:
        return table
    first, last = analysis.picture_iterations
    chosen = table["iteration"].between(first, last if last is not None else table["iteration"].max())
    return table[(table["phase"] != TRAINING) | chosen]
