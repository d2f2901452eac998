"""worker-N.env, read as DeepRacer-for-Cloud's `scripts/training/prepare-config.py` reads it.

prepare-config.py (deepracer-for-cloud 2eb1a1f1) does not read worker-N.env with the shell: it takes every line that
does not start with `#`, splits it with `line.split('=')` and puts the pairs into its environment as they are. So
quotes, white space and `$VAR` stay part of the value (only DR_OA_OBJECT_POSITIONS has its double quotes removed,
later), and a line without exactly one `=` stops it. racer refuses those lines with the file and line, since the
shell's reading (which run.env gets) and prepare-config's would differ; it skips blank and indented comment lines,
on which prepare-config.py stops.
"""

from __future__ import annotations

from pathlib import Path

from racer.drfc.shell_env import VARIABLE_NAME, Assignment, DrfcFileError, EnvFile, read_text

__all__ = ["OBJECT_POSITIONS_VARIABLE", "read_worker_env"]

OBJECT_POSITIONS_VARIABLE = "DR_OA_OBJECT_POSITIONS"
"""The one variable whose double quotes prepare-config.py removes (`.replace('"','')`)."""


def read_worker_env(path: Path) -> EnvFile:
    assignments: list[Assignment] = []
    for number, line in enumerate(read_text(path).splitlines(), start=1):
        if line.startswith("#") or not line.strip() or line.lstrip().startswith("#"):
            continue
        where = f"{path}:{number}"
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
        assignments.append(Assignment(name, value, path, number))
    return EnvFile(path, tuple(assignments), ())
