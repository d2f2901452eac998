"""Simtrace CSV: one row per environment step, as the SimApp writes `training-simtrace/<n>-iteration.csv`.

The SimApp writes a header line and then `','.join(str(v) for v in row)` per step, so values carry Python's `str()`
formatting: floats in shortest-repr form (`1.0`, `9.999999999999998`), booleans as `True`/`False`, `steps` as a float,
and a progress capped by `min(p, 100)` as the int `100`. A continuous action is the scaled [steering, speed] pair
written as `"[{} {}]".format(steer, speed)` (agent_ctrl/utils.py): `[-25.0 1.6248216569843206]`, one space, no comma. Files in the wild have 15 (2019 logs), 17 (console 2022,
DRfC training), 18 (+obstacle_crash_counter) or 19 (+wall_clock, 2026) columns; all are read. The writer emits 19.
Source: deepracer-simapp v5.3.3 `bundle/markov/metrics/constants.py` (StepMetrics); deepracer-utils
`deepracer/logs/log_utils.py`.
"""

from __future__ import annotations

import enum
import io
import re
from collections.abc import Callable, Iterable, Mapping, Sequence
from os import PathLike

import numpy as np
import pandas as pd

from racer.shared.deepracer.episode_status import EpisodeStatus

__all__ = [
    "SIMTRACE_COLUMNS",
    "SIMTRACE_COLUMN_COUNTS",
    "SimtraceError",
    "SimtraceWriter",
    "format_continuous_action",
    "format_simtrace_row",
    "format_simtrace_value",
    "parse_simtrace_action",
    "read_simtrace",
    "read_simtrace_lines",
]


class SimtraceError(ValueError):
    """A simtrace CSV that cannot be read; the message names the file and the line (1-based, header = line 1)."""


SIMTRACE_COLUMNS: tuple[str, ...] = (
    "episode",
    "steps",
    "X",
    "Y",
    "yaw",
    "steer",
    "throttle",
    "action",
    "reward",
    "done",
    "all_wheels_on_track",
    "progress",
    "closest_waypoint",
    "track_len",
    "tstamp",
    "episode_status",
    "pause_duration",
    "obstacle_crash_counter",
    "wall_clock",
)
SIMTRACE_COLUMN_COUNTS: tuple[int, ...] = (15, 17, 18, 19)
"""Column counts seen in real files; each variant is a prefix of SIMTRACE_COLUMNS."""


def format_continuous_action(values: object) -> str:
    """The SimApp's `"[{} {}]".format(steer, speed)` of the scaled action: `[-25.0 1.6248216569843206]`."""
    array = np.asarray(values, dtype=np.float64)
    if array.shape != (2,):
        raise ValueError(f"a continuous action has 2 values [steering, speed], got shape {array.shape}")
    steering, speed = (float(value) for value in array)
    return f"[{steering} {speed}]"


def format_simtrace_value(value: object) -> str:
    """One field exactly as the SimApp's `str(v)` writes it (numpy scalars count as the Python number they hold)."""
    if isinstance(value, enum.Enum):
        value = value.value
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, bool):
        return "True" if value else "False"
    if isinstance(value, (int, float, str)):
        text = str(value)
    elif isinstance(value, (np.ndarray, list, tuple)):
        text = format_continuous_action(value)
    else:
        raise TypeError(f"cannot write {type(value).__name__} {value!r} to a simtrace")
    if "," in text or "\n" in text or "\r" in text:
        raise ValueError(f"simtrace value {text!r} contains a comma or line break")
    return text


def _columns_for(row: Mapping[str, object]) -> tuple[str, ...]:
    columns = SIMTRACE_COLUMNS[: len(row)]
    if len(row) not in SIMTRACE_COLUMN_COUNTS or set(row) != set(columns):
        missing = [name for name in SIMTRACE_COLUMNS if name not in row]
        extra = sorted(name for name in row if name not in SIMTRACE_COLUMNS)
        raise ValueError(
            f"a simtrace row has the first 15, 17, 18 or 19 of {', '.join(SIMTRACE_COLUMNS)}; "
            f"missing {missing}, unexpected {extra}"
        )
    return columns


def format_simtrace_row(row: Mapping[str, object]) -> str:
    """One CSV line (no line break) with the values in SIMTRACE_COLUMNS order; the row has 15, 17, 18 or 19 keys."""
    return ",".join(format_simtrace_value(row[name]) for name in _columns_for(row))


_BOOL_COLUMNS = frozenset({"done", "all_wheels_on_track"})


class SimtraceWriter:
    """Accumulates step rows of one simtrace file (one iteration of one worker) and serialises them with header.

    Rows are formatted when added, so a bad value fails at the step that produced it.
    """

    def __init__(self, num_columns: int = len(SIMTRACE_COLUMNS)) -> None:
        if num_columns not in SIMTRACE_COLUMN_COUNTS:
            raise ValueError(f"num_columns {num_columns}: allowed: {', '.join(map(str, SIMTRACE_COLUMN_COUNTS))}")
        self.columns: tuple[str, ...] = SIMTRACE_COLUMNS[:num_columns]
        self._lines: list[str] = []

    def add_row(self, row: Mapping[str, object]) -> None:
        """Append one step; the row must have exactly this writer's columns, a known status and real booleans."""
        if set(row) != set(self.columns):
            missing = [name for name in self.columns if name not in row]
            extra = sorted(name for name in row if name not in self.columns)
            raise ValueError(f"simtrace row: missing columns {missing}, unexpected columns {extra}")
        for name in _BOOL_COLUMNS:
            if not isinstance(row[name], (bool, np.bool_)):
                raise ValueError(f"simtrace row: {name} must be a bool, got {row[name]!r}")
        if "episode_status" in row:
            status = row["episode_status"]
            if status not in set(EpisodeStatus):
                raise ValueError(f"simtrace row: episode_status {status!r}; allowed: {', '.join(EpisodeStatus)}")
        self._lines.append(format_simtrace_row(row))

    def extend(self, rows: Iterable[Mapping[str, object]]) -> None:
        for row in rows:
            self.add_row(row)

    def __len__(self) -> int:
        return len(self._lines)

    def clear(self) -> None:
        """Forget the rows (the SimApp starts a new file after each upload)."""
        self._lines.clear()

    def to_bytes(self) -> bytes:
        """Header line plus one line per row, each ending in '\\n' (UTF-8)."""
        lines = [",".join(self.columns), *self._lines]
        return ("\n".join(lines) + "\n").encode("utf-8")


_CONTINUOUS_ACTION = re.compile(r"^\[\s*(\S+)\s+(\S+)\s*\]$")


def parse_simtrace_action(text: str) -> int | tuple[float, float]:
    """A discrete action index, or (steering_deg, speed_mps) from a continuous `[<steer> <speed>]` field."""
    match = _CONTINUOUS_ACTION.match(text)
    if match:
        return float(match.group(1)), float(match.group(2))
    return int(text)


def _parse_bool(text: str) -> bool:
    if text == "True":
        return True
    if text == "False":
        return False
    raise ValueError("expected True or False")


def _parse_status(text: str) -> str:
    return EpisodeStatus(text).value


def _parse_float(text: str) -> float:
    """float(), but without Python-only spellings ('1_0', ' 1 ') that no DeepRacer file contains."""
    if text != text.strip() or "_" in text:
        raise ValueError("not a number")
    return float(text)


def _parse_int(text: str) -> int:
    if text != text.strip() or "_" in text:
        raise ValueError("not an integer")
    return int(text)


_PARSERS: dict[str, Callable[[str], object]] = {
    **{name: _parse_float for name in SIMTRACE_COLUMNS},
    "episode": _parse_int,
    "closest_waypoint": _parse_int,
    "obstacle_crash_counter": _parse_int,
    "done": _parse_bool,
    "all_wheels_on_track": _parse_bool,
    "episode_status": _parse_status,
}
_DTYPES: dict[str, str] = {
    **{name: "float64" for name in SIMTRACE_COLUMNS},
    "episode": "int64",
    "closest_waypoint": "int64",
    "obstacle_crash_counter": "int64",
    "done": "bool",
    "all_wheels_on_track": "bool",
    "episode_status": "str",
}
_EXPECTED: dict[str, str] = {
    "episode": "an integer",
    "closest_waypoint": "an integer",
    "obstacle_crash_counter": "an integer",
    "done": "True or False",
    "all_wheels_on_track": "True or False",
    "episode_status": "one of " + ", ".join(EpisodeStatus),
    "action": "an action index or [<steer> <speed>]",
}


def _parse_action_column(texts: Sequence[str], fail: Callable[[int, str, str], SimtraceError]) -> pd.Series:
    """Discrete files give int64 indices; continuous files keep the `[<steer> <speed>]` strings."""
    continuous = bool(texts) and texts[0].startswith("[")
    for row_index, text in enumerate(texts):
        try:
            parsed = parse_simtrace_action(text)
        except ValueError:
            raise fail(row_index, "action", text) from None
        if isinstance(parsed, tuple) != continuous:
            raise fail(row_index, "action", text)
    if continuous:
        return pd.Series(list(texts), dtype="str")
    return pd.Series([int(text) for text in texts], dtype="int64")


def read_simtrace(path_or_bytes: str | PathLike[str] | bytes, source: str | None = None) -> pd.DataFrame:
    """Read a simtrace CSV (15/17/18/19 columns) into a DataFrame with the CSV's column names and typed columns.

    Types: episode, closest_waypoint, obstacle_crash_counter int64; done, all_wheels_on_track bool; episode_status
    str (validated); action int64 for discrete files, the `[<steer> <speed>]` strings for continuous ones; all
    other columns float64 (`steps` too, as the SimApp counts it as a float).

    pandas' C parser reads the file (its one float converter since pandas 3.1 is the round-trip one, so every float is
    Python's `float()` of its text; the `float_precision` argument is deprecated);
    when it cannot, the line parser reads it again to name the file, line and field at fault (SimtraceError).
    """
    if isinstance(path_or_bytes, (bytes, bytearray)):
        raw = bytes(path_or_bytes)
        name = source or "<simtrace bytes>"
    else:
        with open(path_or_bytes, "rb") as handle:
            raw = handle.read()
        name = source or str(path_or_bytes)
    try:
        frame = _read_with_pandas(raw)
    except (ValueError, TypeError, OverflowError, pd.errors.ParserError):  # UnicodeDecodeError is a ValueError
        frame = None
    if frame is not None:
        return frame
    return read_simtrace_lines(raw, name)


_TEXT_READ = _BOOL_COLUMNS | {"action"}
"""Columns the fast path reads as text and converts itself: pandas' own booleans also take true/TRUE, which no
simtrace holds (the SimApp writes str(bool)) and the line parser refuses."""


def _read_with_pandas(raw: bytes) -> pd.DataFrame | None:
    """The fast path; None (or an exception) when the file is not a well-formed simtrace."""
    first_line, _, body = raw.partition(b"\n")
    header = tuple(first_line.decode("utf-8").removesuffix("\r").split(","))
    if len(header) not in SIMTRACE_COLUMN_COUNTS or header != SIMTRACE_COLUMNS[: len(header)]:
        return None
    rows = body.count(b"\n") + (1 if body and not body.endswith(b"\n") else 0)
    if body.count(b",") != rows * (len(header) - 1) or b"\n\n" in body or body.startswith(b"\n"):
        return None  # a short, long or blank line: the line parser names it
    frame = pd.read_csv(
        io.BytesIO(raw),
        engine="c",
        dtype={column: ("str" if column in _TEXT_READ else _DTYPES[column]) for column in header},
        keep_default_na=False,
        na_filter=False,
        encoding="utf-8",
    )
    if len(frame) != rows or tuple(frame.columns) != header:
        return None
    if "episode_status" in frame and not frame["episode_status"].isin(list(EpisodeStatus)).all():
        return None
    actions = frame["action"]
    if len(actions) and actions.iloc[0].startswith("["):
        if not actions.str.fullmatch(_CONTINUOUS_ACTION.pattern).all():
            return None
        frame["action"] = _continuous_texts(actions)
    else:
        if not actions.str.fullmatch(r"[+-]?[0-9]+").all():
            return None
        frame["action"] = actions.astype("int64")
    for column in _BOOL_COLUMNS & set(header):
        texts = frame[column]
        if not texts.isin(("True", "False")).all():
            return None
        frame[column] = (texts == "True").astype("bool")
    return frame


def _continuous_texts(actions: pd.Series) -> pd.Series:
    """The action strings, checked as the line parser checks them (two numbers)."""
    for text in actions:
        parse_simtrace_action(text)  # ValueError: the line parser names the line
    return actions.astype("str")


def read_simtrace_lines(raw: bytes, name: str) -> pd.DataFrame:
    """The line parser: slow, but it names the file, line and field of the first thing that is not a simtrace."""
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as error:
        raise SimtraceError(f"{name}: not UTF-8 text (byte {error.start})") from None
    lines = text.split("\n")
    if lines and lines[-1] == "":
        lines.pop()
    lines = [line[:-1] if line.endswith("\r") else line for line in lines]
    if not lines:
        raise SimtraceError(f"{name}: line 1: empty file, expected a header starting with 'episode,steps'")
    header = tuple(lines[0].split(","))
    if len(header) not in SIMTRACE_COLUMN_COUNTS or header != SIMTRACE_COLUMNS[: len(header)]:
        raise SimtraceError(
            f"{name}: line 1: header {lines[0]!r} is not a simtrace header; expected the first 15, 17, 18 or 19 of "
            f"{','.join(SIMTRACE_COLUMNS)}"
        )

    width = len(header)
    values: list[list[str]] = [[] for _ in header]
    for line_number, line in enumerate(lines[1:], start=2):
        fields = line.split(",")
        if len(fields) != width:
            raise SimtraceError(f"{name}: line {line_number}: {len(fields)} fields, the header has {width}")
        for column, field in zip(values, fields, strict=True):
            column.append(field)

    def fail(row_index: int, column: str, value: str) -> SimtraceError:
        expected = _EXPECTED.get(column, "a number")
        return SimtraceError(f"{name}: line {row_index + 2}: {column}: {value!r} is not {expected}")

    data: dict[str, pd.Series] = {}
    for column, texts in zip(header, values, strict=True):
        if column == "action":
            data[column] = _parse_action_column(texts, fail)
            continue
        parse = _PARSERS[column]
        parsed = []
        for row_index, field in enumerate(texts):
            try:
                parsed.append(parse(field))
            except ValueError:
                raise fail(row_index, column, field) from None
        data[column] = pd.Series(parsed, dtype=_DTYPES[column])
    return pd.DataFrame(data, columns=list(header))
