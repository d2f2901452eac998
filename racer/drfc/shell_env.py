"""run.env and system.env, read as DeepRacer-for-Cloud's `bin/activate.sh` reads them.

activate.sh (deepracer-for-cloud 2eb1a1f1, `dr-update-env`) does not `source` these files. It drops the lines that
start with `#`, splits the rest at white space (`for l in $LINES`: quotes do not hold words together there), cuts
each word at `=` (`cut -f1 -d=` is the name, `cut -f2 -d=` the value: only the text up to a second `=`) and runs
`eval "export NAME=VALUE"`. So a value is shell text: quotes are removed and `$VAR` / `${VAR}` expand to what an
earlier line set (system.env is read before run.env). This module reads that subset: `NAME=VALUE` with or without
`export`, comments (whole lines, or after the value), single and double quotes, backslash escapes, `$VAR`, `${VAR}`,
`${VAR:-word}` and `${VAR-word}`. A line that would not do in DRfC what it says (white space inside a value, an
unquoted `;`, a command substitution, an unterminated quote) is refused with its file and line; `<NAME>` values are
bin/init.sh's placeholders, on which the shell fails, so they leave the variable unset, as in DRfC.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from racer.shared.user_errors import RunConfigError

__all__ = ["Assignment", "DrfcFileError", "EnvFile", "VARIABLE_NAME", "read_shell_env", "read_text"]

VARIABLE_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
PLACEHOLDER = re.compile(r"<[A-Za-z0-9_]+>")
"""bin/init.sh's `<CLOUD_REPLACE>`-style values in the templates (defaults/template-system.env)."""
SPECIAL_PARAMETERS = "0123456789@*#?$!-"
SHELL_OPERATORS = ";&|<>()"


class DrfcFileError(RunConfigError):
    """A DRfC env file that cannot be read as DRfC reads it; the message names the file and line."""


@dataclass(frozen=True)
class Assignment:
    """One variable set by one line of one file."""

    name: str
    value: str
    path: Path
    line: int

    @property
    def where(self) -> str:
        return f"{self.path}:{self.line}"


@dataclass(frozen=True)
class EnvFile:
    path: Path
    assignments: tuple[Assignment, ...]
    notes: tuple[str, ...]
    """What the reader did that the user may not expect (placeholders, references to unset variables)."""


def read_text(path: Path) -> str:
    try:
        return path.read_text(encoding="utf-8")
    except UnicodeDecodeError as error:
        raise DrfcFileError(f"{path}: not UTF-8 text ({error.reason} at byte {error.start})") from None
    except OSError as error:
        raise DrfcFileError(f"{path}: cannot read it: {error.strerror}") from None


def read_shell_env(path: Path, defined: Mapping[str, str]) -> EnvFile:
    """The assignments of `path`; `defined`: what earlier files set (and DR_DIR), for `$VAR` references."""
    values = dict(defined)
    assignments: list[Assignment] = []
    notes: list[str] = []
    placeholders: list[str] = []
    for number, text in enumerate(read_text(path).splitlines(), start=1):
        assigned = _read_line(text, f"{path}:{number}", values, notes)
        if isinstance(assigned, str):
            placeholders.append(f"{assigned} (line {number})")
        elif assigned is not None:
            name, value = assigned
            values[name] = value
            assignments.append(Assignment(name, value, path, number))
    if placeholders:
        notes.append(
            f"{path}: bin/init.sh's placeholders, never filled in, on which the shell fails, so these stay unset "
            f"(as in DRfC): {', '.join(placeholders)}"
        )
    return EnvFile(path, tuple(assignments), tuple(notes))


def _read_line(text: str, where: str, values: dict[str, str], notes: list[str]) -> tuple[str, str] | str | None:
    """(name, value); the name alone for a placeholder value (left unset); None for a comment or blank line."""
    words = text.split()
    if not words or words[0].startswith("#"):
        return None  # activate.sh's grep drops column-0 comments; an indented one only sets junk names there
    if words[0] == "export" and len(words) > 1:
        words = words[1:]  # activate.sh sets a variable named `export` and then this one: the same in effect
    word, rest = words[0], words[1:]
    if rest and not rest[0].startswith("#"):
        raise DrfcFileError(
            f"{where}: {text.strip()!r}: white space inside the line: DRfC's activate.sh splits each line at white "
            f"space (quotes do not hold words together there), so this line does not set what it says; write the "
            f"value without spaces"
        )
    name, equals, after = word.partition("=")
    if not equals:
        raise DrfcFileError(f"{where}: {word!r} is not NAME=VALUE")
    if not VARIABLE_NAME.fullmatch(name):
        raise DrfcFileError(f"{where}: {name!r} is not a shell variable name")
    value_text, second_equals, _dropped = after.partition("=")
    if PLACEHOLDER.fullmatch(value_text):
        return name
    value = _shell_word(value_text, where, values, notes)
    if second_equals:
        notes.append(
            f"{where}: {name}: DRfC's activate.sh keeps only the text before the second '=' (cut -f2 -d=), so "
            f"{name} is {value!r} in DRfC and in racer"
        )
    return name, value


def _shell_word(text: str, where: str, values: Mapping[str, str], notes: list[str]) -> str:
    """The value of one unquoted shell word: quotes removed, escapes and references resolved."""
    out: list[str] = []
    i = 0
    while i < len(text):
        c = text[i]
        if c == "'":
            end = text.find("'", i + 1)
            if end < 0:
                raise DrfcFileError(f"{where}: a ' quote is not closed")
            out.append(text[i + 1 : end])
            i = end + 1
        elif c == '"':
            i, part = _double_quoted(text, i + 1, where, values, notes)
            out.append(part)
        elif c == "\\":
            if i + 1 == len(text):
                raise DrfcFileError(f"{where}: a backslash ends the line")
            out.append(text[i + 1])
            i += 2
        elif c == "$":
            i, part = _dollar(text, i, where, values, notes)
            out.append(part)
        elif c == "`":
            raise _command_substitution(where)
        elif c in SHELL_OPERATORS:
            raise DrfcFileError(
                f"{where}: an unquoted {c!r}: the shell ends the value there (activate.sh runs each line through "
                f"eval); put the value in quotes"
            )
        else:
            out.append(c)
            i += 1
    return "".join(out)


def _double_quoted(text: str, start: int, where: str, values: Mapping[str, str], notes: list[str]) -> tuple[int, str]:
    """(index after the closing quote, the text) of a double-quoted part starting at `start`."""
    out: list[str] = []
    i = start
    while i < len(text):
        c = text[i]
        if c == '"':
            return i + 1, "".join(out)
        if c == "\\" and i + 1 < len(text) and text[i + 1] in '$`"\\':
            out.append(text[i + 1])
            i += 2
        elif c == "$":
            i, part = _dollar(text, i, where, values, notes)
            out.append(part)
        elif c == "`":
            raise _command_substitution(where)
        else:
            out.append(c)
            i += 1
    raise DrfcFileError(f'{where}: a " quote is not closed')


def _dollar(text: str, i: int, where: str, values: Mapping[str, str], notes: list[str]) -> tuple[int, str]:
    """A `$` at `i`: (index after the reference, its value)."""
    following = text[i + 1 : i + 2]
    if following == "(":
        raise _command_substitution(where)
    if following == "{":
        end = _closing_brace(text, i + 2, where)
        return end + 1, _braced(text[i + 2 : end], where, values, notes)
    if following and following in SPECIAL_PARAMETERS:
        raise DrfcFileError(f"{where}: ${following} is a parameter of a running shell; racer reads only the files")
    match = VARIABLE_NAME.match(text, i + 1)
    if match is None:
        return i + 1, "$"  # a `$` before anything else stays a `$` in the shell too
    return match.end(), _lookup(match.group(), where, values, notes)


def _closing_brace(text: str, start: int, where: str) -> int:
    depth = 1
    for index in range(start, len(text)):
        if text[index] == "{":
            depth += 1
        elif text[index] == "}":
            depth -= 1
            if depth == 0:
                return index
    raise DrfcFileError(f"{where}: a ${{ is not closed")


def _braced(inner: str, where: str, values: Mapping[str, str], notes: list[str]) -> str:
    """`${NAME}`, `${NAME:-word}` (word when NAME is unset or empty) or `${NAME-word}` (word when unset)."""
    match = VARIABLE_NAME.match(inner)
    if match is None:
        raise DrfcFileError(f"{where}: ${{{inner}}} is not a variable reference")
    name, operator_and_word = match.group(), inner[match.end() :]
    if not operator_and_word:
        return _lookup(name, where, values, notes)
    for operator in (":-", "-"):
        if operator_and_word.startswith(operator):
            word = operator_and_word[len(operator) :]
            current = values.get(name)
            if current is None or (operator == ":-" and current == ""):
                return _shell_word(word, where, values, notes)
            return current
    raise DrfcFileError(f"{where}: ${{{inner}}}: racer reads $NAME, ${{NAME}}, ${{NAME:-word}} and ${{NAME-word}} only")


def _lookup(name: str, where: str, values: Mapping[str, str], notes: list[str]) -> str:
    if name in values:
        return values[name]
    notes.append(
        f"{where}: ${name} is not set in the DRfC files; the shell would take it from its own environment, racer "
        f"reads only the files, so it is empty"
    )
    return ""


def _command_substitution(where: str) -> DrfcFileError:
    return DrfcFileError(f"{where}: a command substitution ($(...) or `...`): racer runs no commands from env files")
