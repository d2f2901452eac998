"""The compare tests' browser; their two short real runs are tests/conftest.py's `two_short_runs` (trained once,
shared with the viewer's run list)."""

from __future__ import annotations

import pytest

from tests.browser import chromium


@pytest.fixture
def browser():
    """A headless chromium (tests.browser)."""
    yield from chromium(window="1400,1000")
