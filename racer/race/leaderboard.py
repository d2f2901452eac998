"""The board: leaderboard.json and leaderboard.csv under DeepRacer on AWS's stat names.

Columns (DRoA's SubmissionStats / leaderboard names where it has them): rank, entrant (racer: the entrant's name;
DRoA: racerAlias), rankingScore (the timing method's figure, ms), completedLapCount, bestLapTime, avgLapTime,
totalLapTime (ms), resetCount, avgResets, offTrackCount, collisionCount; racer adds lapCount, dnfReason and
errorCode. Nothing time- or machine-dependent is written, so one seed gives one board.

HEAD_TO_MODEL ranks each car's laps by the timing method, as a time trial. F1 ranks by the multi-car result's
finishing order: the cars that completed every lap (maximumLaps) by the time of their last crossing (rankingScore:
that time, ms from the start), then the others as DNF rows in the order they reached (distance raced), each with
its reason, then the entrants that could not race.
"""

from __future__ import annotations

import csv
import io
import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from racer.race.race_file import RaceDefinition
from racer.race.ranking import Lap, Standing, rank_entrants, submission_stats

CSV_COLUMNS = (
    "rank",
    "entrant",
    "rankingScore",
    "completedLapCount",
    "bestLapTime",
    "avgLapTime",
    "totalLapTime",
    "resetCount",
    "avgResets",
    "offTrackCount",
    "collisionCount",
    "lapCount",
    "dnfReason",
    "errorCode",
)


def f1_standings(definition: RaceDefinition, results: Sequence[dict[str, Any]]) -> tuple[Standing, ...]:
    """F1: the finishing order; finishers ranked, the other cars DNF in the order they reached, then the rest."""
    raced = sorted((r for r in results if r.get("multi_car")), key=lambda r: r["multi_car"]["finishingPlace"])
    standings: list[Standing] = []
    rank = 0
    for result in raced:
        car = result["multi_car"]
        laps = [Lap.from_metrics_entry(entry) for entry in result.get("metrics", [])]
        stats = submission_stats(laps, definition.minimum_laps)
        if car["finished"]:
            rank += 1
            standings.append(Standing(result["entrant"], stats, car["finishTimeMs"], rank, None))
            continue
        reason = (
            f"did not finish: {car['completedLaps']} of {car['laps']} laps, {car['racedPct'] / 100.0:.2f} laps raced"
            f" from the line (place {car['finishingPlace']} on the road)"
        )
        standings.append(Standing(result["entrant"], stats, None, None, reason, result.get("code")))
    for result in results:
        if not result.get("multi_car"):
            standings.append(
                Standing(
                    result["entrant"], None, None, None, result.get("reason") or "did not race", result.get("code")
                )
            )
    return tuple(standings)


def standings_from_results(definition: RaceDefinition, results: Sequence[dict[str, Any]]) -> tuple[Standing, ...]:
    if definition.race_type == "F1":
        return f1_standings(definition, results)
    rows = []
    for result in results:
        metrics = result.get("metrics")
        laps = None if metrics is None else [Lap.from_metrics_entry(entry) for entry in metrics]
        rows.append((result["entrant"], laps, result.get("reason"), result.get("code")))
    return rank_entrants(rows, timing_method=definition.timing_method, minimum_laps=definition.minimum_laps)


def board_rows(standings: Sequence[Standing]) -> list[dict[str, Any]]:
    rows = []
    for standing in standings:
        stats = standing.stats
        row: dict[str, Any] = {"rank": standing.rank, "entrant": standing.entrant, "rankingScore": standing.score_ms}
        for name in CSV_COLUMNS[3:12]:
            row[name] = getattr(stats, name) if stats is not None else None
        row["dnfReason"] = standing.dnf_reason
        row["errorCode"] = standing.error_code
        rows.append(row)
    return rows


def board_json(
    definition: RaceDefinition,
    route: str,
    seed: int,
    standings: Sequence[Standing],
    results: Sequence[dict],
    race_videos: dict[str, str] | None = None,
) -> dict[str, Any]:
    """`race_videos`: the race's own videos (videos/ file names), such as the all-cars top view of a multi-car race."""
    by_name = {result["entrant"]: result for result in results}
    entries = []
    for row in board_rows(standings):
        result = by_name.get(row["entrant"], {})
        entries.append(
            {
                **row,
                "laps": result.get("metrics", []),
                "endedBy": result.get("ended_by"),
                "checkpoint": result.get("checkpoint"),
                "videos": result.get("videos", {}),
                "sectorTimes": (result.get("best_lap") or {}).get("sector_times_s"),
                **({"multiCar": result["multi_car"]} if result.get("multi_car") else {}),
            }
        )
    board = {"race": definition.to_dict(), "route": route, "seed": seed, "leaderboard": entries}
    return {**board, "raceVideos": race_videos} if race_videos else board


def board_csv(standings: Sequence[Standing]) -> str:
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=CSV_COLUMNS, lineterminator="\n")
    writer.writeheader()
    for row in board_rows(standings):
        writer.writerow({key: "" if value is None else value for key, value in row.items()})
    return buffer.getvalue()


def write_board(
    out_dir: Path,
    definition: RaceDefinition,
    route: str,
    seed: int,
    standings: Sequence[Standing],
    results,
    race_videos: dict[str, str] | None = None,
) -> dict[str, Path]:
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = {"json": out_dir / "leaderboard.json", "csv": out_dir / "leaderboard.csv"}
    board = board_json(definition, route, seed, standings, results, race_videos)
    paths["json"].write_text(json.dumps(board, indent=2) + "\n")
    paths["csv"].write_text(board_csv(standings))
    return paths


def format_board(standings: Sequence[Standing], timing_method: str) -> str:
    """The table printed at the end of `racer race`."""
    header = f"{'rank':>4}  {'entrant':<24} {timing_method:>14}  {'laps':>4}  {'best':>8}  {'resets':>6}  note"
    lines = [header, "-" * len(header)]
    for standing in standings:
        stats = standing.stats
        score = f"{standing.score_ms / 1000:.3f} s" if standing.score_ms is not None and standing.rank else "-"
        best = f"{stats.bestLapTime / 1000:.3f}" if stats and stats.bestLapTime is not None else "-"
        laps = stats.completedLapCount if stats else 0
        resets = stats.resetCount if stats else 0
        note = standing.dnf_reason or ""
        if standing.error_code:
            note = f"{standing.error_code}: {note}"
        rank = str(standing.rank) if standing.rank else "DNF"
        lines.append(f"{rank:>4}  {standing.entrant:<24} {score:>14}  {laps:>4}  {best:>8}  {resets:>6}  {note}")
    return "\n".join(lines)
