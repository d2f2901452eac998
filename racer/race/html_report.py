"""leaderboard.html: the ranked table, each entrant's videos, the top entrants' best laps on one track map coloured
by speed (a matplotlib PNG embedded as data), and their sector times side by side."""

from __future__ import annotations

import base64
import html
import io
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from racer.race.race_file import RaceDefinition

TOP_ON_MAP = 3


def _ms(value: Any) -> str:
    return "-" if value is None else f"{value / 1000:.3f}"


def track_map_png(route: str, laps: Sequence[tuple[str, dict[str, Any]]]) -> bytes | None:
    """The route's borders and each best lap's path coloured by speed, one panel per entrant."""
    if not laps:
        return None
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from racer.shared.sim.tracks.track import Track

    track = Track.load(route)
    speeds = np.concatenate([np.asarray(trace["speed_mps"]) for _, trace in laps])
    vmax = float(max(speeds.max(), 0.1))
    figure, axes = plt.subplots(1, len(laps), figsize=(4.2 * len(laps), 4.0), squeeze=False)
    scatter = None
    for axis, (name, trace) in zip(axes[0], laps, strict=True):
        for border in (track.inner_border, track.outer_border):
            axis.plot(border[:, 0], border[:, 1], color="0.6", linewidth=1)
        scatter = axis.scatter(trace["x"], trace["y"], c=trace["speed_mps"], cmap="plasma", s=6, vmin=0, vmax=vmax)
        axis.set_title(f"{name}: lap {trace['lap']}, {trace['lap_time_s']:.3f} s", fontsize=9)
        axis.set_aspect("equal")
        axis.set_axis_off()
    if scatter is not None:
        figure.colorbar(scatter, ax=axes[0].tolist(), label="speed (m/s)", shrink=0.8)
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=90)
    plt.close(figure)
    return buffer.getvalue()


def render_html(definition: RaceDefinition, board: dict[str, Any], map_png: bytes | None) -> str:
    entries = board["leaderboard"]
    esc = html.escape
    rows = []
    for entry in entries:
        videos = " ".join(
            f'<a href="videos/{esc(path)}">{esc(view.removeprefix("camera-"))}</a>'
            for view, path in sorted(entry.get("videos", {}).items())
        )
        note = entry.get("dnfReason") or ""
        if entry.get("errorCode"):
            note = f"<code>{esc(entry['errorCode'])}</code> {esc(note)}"
        else:
            note = esc(note)
        rows.append(
            "<tr>"
            f"<td>{entry['rank'] or 'DNF'}</td><td>{esc(entry['entrant'])}</td>"
            f"<td>{_ms(entry['rankingScore']) if entry['rank'] else '-'}</td>"
            f"<td>{entry['completedLapCount'] if entry['completedLapCount'] is not None else 0}</td>"
            f"<td>{_ms(entry['bestLapTime'])}</td><td>{_ms(entry['avgLapTime'])}</td>"
            f"<td>{entry['resetCount'] if entry['resetCount'] is not None else '-'}</td>"
            f"<td>{entry['offTrackCount'] if entry['offTrackCount'] is not None else '-'}</td>"
            f"<td>{entry['collisionCount'] if entry['collisionCount'] is not None else '-'}</td>"
            f"<td>{videos}</td><td>{note}</td></tr>"
        )
    sectors = [e for e in entries if e.get("rank") and e.get("sectorTimes")][:TOP_ON_MAP]
    sector_html = ""
    if sectors:
        count = len(sectors[0]["sectorTimes"])
        head = "".join(f"<th>{esc(e['entrant'])}</th>" for e in sectors)
        body = []
        for index in range(count):
            times = [e["sectorTimes"][index] for e in sectors]
            known = [t for t in times if t is not None]
            fastest = min(known) if known else None
            cells = "".join(
                f"<td{' class=best' if t is not None and t == fastest else ''}>{'-' if t is None else f'{t:.3f}'}</td>"
                for t in times
            )
            body.append(f"<tr><td>sector {index + 1}</td>{cells}</tr>")
        sector_html = (
            "<h2>Sector times of the best laps (s)</h2><p>The lap in three equal parts of progress; the fastest "
            f"in each sector is marked.</p><table><tr><th></th>{head}</tr>{''.join(body)}</table>"
        )
    field_html = ""
    top_view = (board.get("raceVideos") or {}).get("allCarsTopView")
    if top_view:
        field_html = (
            "<h2>The race from above</h2><p>Every car on one top view, numbered by grid place "
            f'(<a href="videos/{esc(top_view)}">{esc(top_view)}</a>).</p>'
            f'<video controls preload="metadata" src="videos/{esc(top_view)}"></video>'
        )
    map_html = ""
    if map_png is not None:
        encoded = base64.b64encode(map_png).decode()
        map_html = f'<h2>Best laps</h2><img alt="best laps coloured by speed" src="data:image/png;base64,{encoded}">'
    race = definition
    limits = (
        f"minimumLaps {race.minimum_laps}, maximumLaps {race.maximum_laps}, maxTimeInMinutes "
        f"{race.max_time_minutes:g}, continuousLap {str(race.continuous_lap or race.multi_car).lower()}"
        f"{' (every multi-car race drives its laps on)' if race.multi_car and not race.continuous_lap else ''}"
        ", off-track penalty "
        f"{race.off_track_penalty_s:g} s, collision penalty {race.collision_penalty_s:g} s"
    )
    return f"""<!doctype html>
<html><head><meta charset="utf-8"><title>{esc(race.name)}: leaderboard</title>
<style>body{{font-family:sans-serif;margin:2em}}table{{border-collapse:collapse}}
td,th{{border:1px solid #ccc;padding:4px 8px;text-align:right}}td:nth-child(2),td:last-child{{text-align:left}}
.best{{background:#d4f7d4;font-weight:bold}}</style></head><body>
<h1>{esc(race.name)}</h1>
<p>{esc(race.description)}</p>
<p>{esc(race.race_type)} on {esc(board["route"])} ({esc(race.track_id)}{", " + esc(race.track_direction) if race.track_direction else ""}),
ranked by {esc(race.timing_method)} (lower wins); {esc(limits)}; seed {board["seed"]}.</p>
<table><tr><th>rank</th><th>entrant</th><th>{esc("finish time" if race.race_type == "F1" else race.timing_method)} (s)</th><th>laps</th><th>best lap (s)</th>
<th>avg lap (s)</th><th>resets</th><th>off track</th><th>crashes</th><th>videos</th><th>DNF reason</th></tr>
{"".join(rows)}</table>
{field_html}
{map_html}
{sector_html}
</body></html>
"""


def write_html(out_dir: Path, definition: RaceDefinition, board: dict[str, Any], results: Sequence[dict]) -> Path:
    by_name = {result["entrant"]: result for result in results}
    top = [
        (entry["entrant"], by_name[entry["entrant"]]["best_lap"])
        for entry in board["leaderboard"]
        if entry.get("rank") and by_name.get(entry["entrant"], {}).get("best_lap")
    ][:TOP_ON_MAP]
    path = out_dir / "leaderboard.html"
    path.write_text(render_html(definition, board, track_map_png(board["route"], top)))
    return path
