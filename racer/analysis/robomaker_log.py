"""Simtrace rows from a simulation (robomaker) log: DeepRacer logs every step as `SIM_TRACE_LOG:<csv fields>`.

Leaderboard and some console evaluations leave only this log. The fields are the simtrace columns in order
(formatted with fewer decimals), so the lines become a simtrace CSV for the shared reader; errors are re-labelled
with the log's own line numbers.
"""

from __future__ import annotations

import re

from racer.shared.deepracer.simtrace import SIMTRACE_COLUMNS, SimtraceError

MARKER = "SIM_TRACE_LOG:"


def simtrace_csv_from_log(text: str, name: str) -> tuple[bytes, list[int]]:
    """(CSV bytes with a header, log line number of each CSV data row)."""
    rows, line_numbers = [], []
    for number, line in enumerate(text.splitlines(), start=1):
        _, marker, fields = line.partition(MARKER)
        if marker:
            rows.append(fields.strip())
            line_numbers.append(number)
    if not rows:
        raise SimtraceError(f"{name}: no {MARKER} lines in this log")
    width = rows[0].count(",") + 1
    header = ",".join(SIMTRACE_COLUMNS[:width])
    return (header + "\n" + "\n".join(rows) + "\n").encode("utf-8"), line_numbers


def relabel_error(error: SimtraceError, name: str, line_numbers: list[int]) -> SimtraceError:
    """The reader counts lines of the generated CSV (header = line 1); say which line of the log it was."""
    match = re.search(r": line (\d+): (.*)$", str(error), flags=re.DOTALL)
    if match is None or int(match.group(1)) < 2:
        return SimtraceError(f"{name}: {MARKER} lines: {error}")
    return SimtraceError(f"{name}: line {line_numbers[int(match.group(1)) - 2]}: {match.group(2)}")
