"""The HTML report: one self-contained file (pictures embedded) that can be mailed or opened from a bucket.

`racer analyze` and `racer compare` (racer.compare.page) write theirs with it."""

from __future__ import annotations

import base64
import html
from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd


@dataclass(frozen=True)
class Html:
    """A section's content written as HTML by its maker (who escaped what it took from files)."""

    text: str


@dataclass
class Report:
    title: str
    source: str
    notes: list[str] = field(default_factory=list)
    sections: list[tuple[str, str, Path | pd.DataFrame | Html]] = field(default_factory=list)
    """(heading, one-line caption, PNG path, table or HTML), in reading order; an empty heading or caption is left
    out."""
    style: str = ""
    """CSS added to the report's own (for the classes an Html section uses)."""

    def add_picture(self, heading: str, path: Path, caption: str) -> None:
        self.sections.append((heading, caption, Path(path)))

    def add_table(self, heading: str, table: pd.DataFrame, caption: str) -> None:
        self.sections.append((heading, caption, table))

    def add_html(self, heading: str, html_text: str, caption: str = "") -> None:
        self.sections.append((heading, caption, Html(html_text)))


_STYLE = """
body { font-family: system-ui, sans-serif; margin: 2em auto; max-width: 1400px; color: #222; }
h1 { margin-bottom: 0.2em; } .source { color: #666; margin-top: 0; }
.note { background: #fff6d6; border-left: 4px solid #e0b000; padding: 0.5em 1em; margin: 0.5em 0; }
table { border-collapse: collapse; font-size: 13px; margin: 0.5em 0 1.5em; }
th, td { border: 1px solid #ccc; padding: 3px 8px; text-align: right; } th { background: #f0f0f0; }
img { max-width: 100%; border: 1px solid #ddd; } .caption { color: #555; font-size: 14px; }
"""


def format_table(table: pd.DataFrame) -> pd.DataFrame:
    """Round floats for reading (3 decimals; percentages and rewards to 1) without touching the data files."""
    shown = table.copy()
    for column in shown.columns:
        if pd.api.types.is_float_dtype(shown[column]):
            decimals = 1 if column.endswith(("_pct", "reward", "reward_mean", "reward_std")) else 3
            shown[column] = shown[column].round(decimals)
        if column.endswith("completion_rate"):
            shown[column] = (100 * table[column]).round(1)
    return shown.rename(columns=lambda c: c.replace("completion_rate", "completion_pct"))


def render_html(report: Report) -> str:
    parts = [
        "<!DOCTYPE html>",
        f"<html><head><meta charset='utf-8'><title>{html.escape(report.title)}</title>"
        f"<style>{_STYLE}{report.style}</style></head><body>",
        f"<h1>{html.escape(report.title)}</h1>",
        f"<p class='source'>source: {html.escape(report.source)}</p>",
    ]
    parts += [f"<div class='note'>{html.escape(note)}</div>" for note in report.notes]
    for heading, caption, content in report.sections:
        if heading:
            parts.append(f"<h2>{html.escape(heading)}</h2>")
        if caption:
            parts.append(f"<p class='caption'>{html.escape(caption)}</p>")
        if isinstance(content, Html):
            parts.append(content.text)
        elif isinstance(content, Path):
            encoded = base64.b64encode(content.read_bytes()).decode("ascii")
            parts.append(f"<img alt='{html.escape(heading)}' src='data:image/png;base64,{encoded}'>")
        else:
            parts.append(format_table(content).to_html(index=False, na_rep="–", border=0))
    parts.append("</body></html>")
    return "\n".join(parts)


def write_html(report: Report, path: Path) -> Path:
    path.write_text(render_html(report), encoding="utf-8")
    return path
