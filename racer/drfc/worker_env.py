"""worker-N.env, read as DeepRacer-for-Cloud's `scripts/training/prepare-config.py` reads it.

prepare-config.py (deepracer-for-cloud 2eb1a1f1, lines 147-151) does not read worker-N.env with the shell: it opens
it in Python's text mode (so CRLF line ends are line ends there), takes every line that does not start with `#`,
splits it with `line.split('=')` and puts the pairs into its environment as they are. So quotes, white space,
`$VAR` and a trailing `# comment` stay part of the value (only DR_OA_OBJECT_POSITIONS has its double quotes removed,
later), and a line without exactly one `=` (a blank line, an indented comment) stops it. racer refuses the lines
whose value the shell would read otherwise (which run.env gets), with the file and line; it reads a trailing comment
as a comment and skips blank and indented comment lines, each with a warning naming the line, since DRfC fails there.
"""

from __future__ import annotations

import re
from pathlib import Path

from racer.drfc.shell_env import VARIABLE_NAME, Assignment, DrfcFileError, EnvFile, crlf_lines, line_list, read_text

__all__ = ["OBJECT_POSITIONS_VARIABLE", "read_worker_env"]

OBJECT_POSITIONS_VARIABLE = "DR_OA_OBJECT_POSITIONS"
"""The one variable whose double quotes prepare-config.py removes (`.replace('"','')`)."""
TRAILING_COMMENT = re.compile(r"\s+#")
"""Where a comment after a value starts, as a reader of the file means it (prepare-config.py keeps it)."""


def read_worker_env(path: Path) -> EnvFile:
    text = read_text(path)
    assignments: list[Assignment] = []
    warnings: list[str] = []
    blank: list[int] = []
    for number, line in enumerate(text.splitlines(), start=1):
        where = f"{path}:{number}"
        if line.startswith("#"):
            continue
        if not line.strip():
            blank.append(number)
            continue
        if line.lstrip().startswith("#"):
            warnings.append(
                f"{where}: an indented comment: DRfC's prepare-config.py skips only lines that start with '#' and "
                f"reads this one as NAME=VALUE ({_drfc_reading(line)}); racer skips it; start it with '#' for DRfC"
            )
            continue
        comment = TRAILING_COMMENT.search(line)
        if comment is not None and "=" in line[: comment.start()]:
            warnings.append(
                f"{where}: a comment after the value: DRfC's prepare-config.py {_drfc_reading(line)}; racer reads "
                f"the value before it, {line[: comment.start()].partition('=')[2]!r}; put the comment on a line "
                f"of its own for DRfC"
            )
            line = line[: comment.start()]
        assignments.append(_assignment(line, where, path, number))
    if blank:
        warnings.append(
            f"{path}:{blank[0]}: blank {line_list(blank)}: DRfC's prepare-config.py stops on a blank line (it is "
            f"no NAME=VALUE pair: dict() raises ValueError); racer skips them; remove them for DRfC"
        )
    crlf = crlf_lines(text)
    if crlf:
        warnings.append(
            f"{path}:{crlf[0]}: Windows line ends (CRLF) on {line_list(crlf)}: DRfC's prepare-config.py reads "
            f"this file in Python's text mode, which takes them as line ends, and so does racer; DRfC's "
            f"activate.sh does not (in a run.env or system.env they break the run), so convert it (dos2unix)"
        )
    return EnvFile(path, tuple(assignments), (), tuple(warnings))


def _drfc_reading(line: str) -> str:
    """What prepare-config.py makes of a line (`dict(tuple(line.split('=')) ...)`)."""
    parts = line.split("=")
    if len(parts) != 2:
        return "stops on this line: it is not exactly one NAME=VALUE"
    return f"sets a variable named {parts[0]!r} to {parts[1]!r}"


def _assignment(line: str, where: str, path: Path, number: int) -> Assignment:
    parts = line.split("=")
    if len(parts) != 2:
        raise DrfcFileError(
            f"{where}: {line!r}: DRfC's prepare-config.py reads each line as exactly one NAME=VALUE "
            f"(line.split('=')) and stops on this one"
        )
    name, value = parts
    if not VARIABLE_NAME.fullmatch(name):
        raise DrfcFileError(
            f"{where}: DRfC's prepare-config.py would set a variable named {name!r}: write NAME=VALUE with "
            f"nothing before the name (no `export`, no spaces)"
        )
    if value != value.strip():
        raise DrfcFileError(
            f"{where}: {name}: white space around the value, which DRfC's prepare-config.py keeps as part of it"
        )
    quotes = "'" if name == OBJECT_POSITIONS_VARIABLE else "'\""
    if any(quote in value for quote in quotes):
        raise DrfcFileError(
            f"{where}: {name}: quotes: DRfC's prepare-config.py does not read worker-N.env with the shell, so "
            f"they would be part of the value (it removes double quotes from {OBJECT_POSITIONS_VARIABLE} "
            f"only); remove them"
        )
    if "$" in value:
        raise DrfcFileError(
            f"{where}: {name}: DRfC's prepare-config.py does not expand $ references in worker-N.env; write "
            f"the value itself"
        )
    return Assignment(name, value, path, number)
