"""Reading a JSON file so that a syntax error names the file, the line and the column."""

from __future__ import annotations

import json
from os import PathLike


def read_json_file(path: str | PathLike[str], error_type: type[ValueError]) -> object:
    """Parse the JSON document at `path`; malformed text raises `error_type` naming file, line and column."""
    name = str(path)
    with open(path, "rb") as handle:
        raw = handle.read()
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as error:
        raise error_type(f"{name}: not UTF-8 text (byte {error.start}): {error.reason}") from None
    try:
        return json.loads(text)
    except json.JSONDecodeError as error:
        raise error_type(f"{name}: invalid JSON at line {error.lineno}, column {error.colno}: {error.msg}") from None
