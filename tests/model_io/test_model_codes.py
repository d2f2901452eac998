"""The codes are the console's, spelled as in the seed document, each with its human title."""

from __future__ import annotations

from pathlib import Path

import pytest

from racer.model_io import CODE_INFO, ProblemCode

SEEDS = Path(__file__).resolve().parents[2].parent / "shared" / "seeds"


@pytest.fixture(scope="module")
def seed_text() -> str:
    (path,) = SEEDS.glob("000_*.txt")
    return path.read_text()


def test_every_code_of_the_seed_table_is_known(seed_text):
    table = [
        line.split(" ", 1)[0]
        for line in seed_text.splitlines()
        if line.split(" ", 1)[0].isupper() and "_" in line.split(" ", 1)[0]
    ]
    assert table, "the seed's error table was not found"
    assert sorted(table) == sorted(code.value for code in ProblemCode)


@pytest.mark.parametrize("code", list(ProblemCode))
def test_each_code_carries_the_console_title(seed_text, code):
    assert f"{code.value} {CODE_INFO[code].title}" in seed_text
    assert CODE_INFO[code].meaning
