"""Stand-in for racer.shared.deepracer.simtrace until it is committed; delete then. Not a validating parser."""

from __future__ import annotations

import io

import pandas as pd


class SimtraceError(ValueError):
    pass


def read_simtrace(data: bytes, source: str | None = None) -> pd.DataFrame:
    try:
        return pd.read_csv(io.BytesIO(data))
    except (pd.errors.ParserError, UnicodeDecodeError) as error:
        raise SimtraceError(f"{source}: {error}") from error
