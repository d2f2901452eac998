"""run.env and system.env, read as DeepRacer-for-Cloud's `bin/activate.sh` reads them.

activate.sh (deepracer-for-cloud 2eb1a1f1, `dr-update-env`, lines 70-76 and 100-106) does not `source` these files.
It drops the lines that start with `#` (column 0 only), splits the rest at white space (`for l in $LINES`: quotes do
not hold words together there), cuts each word at `=` (`cut -f1 -d=` is the name, `cut -f2 -d=` the value: only the
text up to a second `=`) and runs `eval "export NAME=VALUE"`. So a value is shell text: quotes are removed and `$VAR`
/ `${VAR}` expand to what an earlier word set (system.env is read before run.env). And every word is run, comments
included: `X=False # set X=True to reverse` sets X to True, and so does an indented `# X=True`; racer applies those
as DRfC does, with a warning. This module reads that subset: `NAME=VALUE` with or without `export`, comments,
single and double quotes, backslash escapes, `$VAR`, `${VAR}`, `${VAR:-word}` and `${VAR-word}`. A line that would
not do in DRfC what it says (white space inside a value, an unquoted `;`, a command substitution, an unterminated
quote, a DRfC variable's bare name in a comment) is refused with its file and line; `<NAME>` values are
bin/init.sh's placeholders, on which the shell fails, so they leave the variable unset, as in DRfC. Windows line
ends (CRLF) are read as line ends, with a warning: activate.sh keeps the carriage return in the value.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from racer.drfc.variables import variable
from racer.shared.user_errors import RunConfigError

__all__ = [
    "Assignment", "DrfcFileError", "EnvFile", "VARIABLE_NAME", "crlf_lines", "line_list", "read_shell_env", "read_text",
]  # fmt: skip

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
    warnings: tuple[str, ...] = ()
    """Lines DRfC reads otherwise than they look (CRLF ends, assignments inside comments), each with file:line."""


def read_text(path: Path) -> str:
    """The file's text with its line ends as they are (a CR before LF kept, for crlf_lines)."""
    try:
        return path.read_bytes().decode("utf-8")
    except UnicodeDecodeError as error:
        raise DrfcFileError(f"{path}: not UTF-8 text ({error.reason} at byte {error.start})") from None
    except OSError as error:
        raise DrfcFileError(f"{path}: cannot read it: {error.strerror}") from None


def crlf_lines(text: str) -> list[int]:
    """The numbers of the lines (as str.splitlines numbers them) that end in a Windows line end, CRLF."""
    return [number for number, line in enumerate(text.splitlines(keepends=True), start=1) if line.endswith("\r\n")]


def line_list(numbers: list[int]) -> str:
    """`line 3` or `lines 1-4, 9`."""
    runs: list[list[int]] = []
    for number in numbers:
        if runs and number == runs[-1][1] + 1:
            runs[-1][1] = number
        else:
            runs.append([number, number])
    text = ", ".join(str(a) if a == b else f"{a}-{b}" for a, b in runs)
    return f"line {text}" if len(numbers) == 1 else f"lines {text}"


def read_shell_env(path: Path, defined: Mapping[str, str]) -> EnvFile:
    """The assignments of `path`; `defined`: what earlier files set (and DR_DIR), for `$VAR` references."""
    text = read_text(path)
    values = dict(defined)
    assignments: list[Assignment] = []
    notes: list[str] = []
    warnings: list[str] = []
    placeholders: list[str] = []
    for number, line in enumerate(text.splitlines(), start=1):
        where = f"{path}:{number}"
        for word, in_comment in _words(line, where):
            assigned = _assignment(word, in_comment, where, values, notes)
            if isinstance(assigned, str):
                placeholders.append(f"{assigned} (line {number})")
            elif assigned is not None:
                name, value = assigned
                values[name] = value
                assignments.append(Assignment(name, value, path, number))
                if in_comment:
                    warnings.append(
                        f"{where}: {word!r} inside a comment: DRfC's activate.sh runs every NAME=VALUE word of a line "
                        f"as an assignment, comments included (it drops only lines that start with '#'), so it sets "
                        f"{name}={value!r}, and so does racer; start the line with '#' or reword the comment if "
                        f"that is not what you meant"
                    )
    if placeholders:
        notes.append(
            f"{path}: bin/init.sh's placeholders, never filled in, on which the shell fails, so these stay unset "
            f"(as in DRfC): {', '.join(placeholders)}"
        )
    crlf = crlf_lines(text)
    if crlf:
        warnings.append(
            f"{path}:{crlf[0]}: Windows line ends (CRLF) on {line_list(crlf)}: DRfC's activate.sh keeps the '\\r' "
            f"as part of the value at the end of a line ('True\\r' is not True there), which breaks the run in "
            f"DRfC; racer reads the values without it; convert the file (dos2unix) for DRfC"
        )
    return EnvFile(path, tuple(assignments), tuple(notes), tuple(warnings))


def _words(line: str, where: str) -> list[tuple[str, bool]]:
    """The words of `line` that activate.sh runs as `export NAME=VALUE`, each with whether it is inside a comment.
    Words that start with `#` are dropped: `eval "export #..."` is a comment there."""
    if line.startswith("#"):
        return []  # activate.sh's `grep -v '^#'` drops the line
    words = line.split()
    if len(words) > 1 and words[0] == "export":
        words = words[1:]  # activate.sh sets a variable named `export` and then this one: the same in effect
    comment = next((index for index, word in enumerate(words) if word.startswith("#")), len(words))
    if comment > 1:
        raise DrfcFileError(
            f"{where}: {line.strip()!r}: white space inside the line: DRfC's activate.sh splits each line at white "
            f"space (quotes do not hold words together there), so this line does not set what it says; write the "
            f"value without spaces"
        )
    return [(word, False) for word in words[:comment]] + [
        (word, True) for word in words[comment + 1 :] if not word.startswith("#")
    ]


def _assignment(
    word: str, in_comment: bool, where: str, values: dict[str, str], notes: list[str]
) -> tuple[str, str] | str | None:
    """(name, value); the name alone for a placeholder value (left unset); None for a word of a comment that sets
    nothing racer reads (the shell sets a variable of that name to itself, or fails)."""
    name, equals, after = word.partition("=")
    valid_name = VARIABLE_NAME.fullmatch(name) is not None
    if in_comment and not (equals and valid_name):
        if not equals and valid_name and variable(name) is not None:
            raise DrfcFileError(
                f"{where}: {name} inside a comment: DRfC's activate.sh runs every word of a line as an assignment, "
                f"comments included, and a word without '=' sets the variable of that name to its own name "
                f"({name}={name}); start the line with '#' or reword the comment"
            )
        return None
    if not equals:
        raise DrfcFileError(f"{where}: {word!r} is not NAME=VALUE")
    if not valid_name:
        raise DrfcFileError(f"{where}: {name!r} is not a shell variable name")
    value_text, second_equals, _dropped = after.partition("=")
    if PLACEHOLDER.fullmatch(value_text):
        return name
    try:
        value = _shell_word(value_text, where, values, notes)
    except DrfcFileError as error:
        if not in_comment:
            raise
        raise DrfcFileError(f"{error} (in {word!r}, inside a comment: DRfC's activate.sh runs it too)") from None
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
