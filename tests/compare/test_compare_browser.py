"""The compare page in a real browser (Debian's chromium): its pictures load, the settings that differ are marked
and can be shown alone. The test leaves a screenshot of the whole page at .pytest_cache/d/compare/compare.png."""

from __future__ import annotations

import shutil

import pytest
from click.testing import CliRunner

from racer.compare.cli import compare_command

pytestmark = [pytest.mark.slow, pytest.mark.heavy]  # two real training runs (tests/conftest.py's two_short_runs)

HIGHLIGHT = "rgba(255, 233, 168, 1)"
"""The marked rows' background (racer.compare.page STYLE #ffe9a8)."""

PICTURES = """return [...document.images].map(img => [img.alt, img.complete, img.naturalWidth, img.naturalHeight,
  img.getBoundingClientRect().width]);"""


def test_the_compare_page_reads_in_a_browser(two_short_runs, browser, tmp_path, request):
    page = tmp_path / "compare.html"
    result = CliRunner().invoke(compare_command, [*map(str, two_short_runs), "--out", str(page), "--no-line"])
    assert result.exit_code == 0, result.output
    browser.get(page.as_uri())
    assert browser.title == "racer compare: baseline vs centre-reward"

    pictures = browser.execute_script(PICTURES)
    assert [p[0] for p in pictures] == ["Training", "Evaluation per checkpoint", "Best lap"]
    for alt, complete, width, height, shown_width in pictures:
        assert complete and width >= 900 and height >= 350, (alt, width, height)
        assert shown_width >= 900, (alt, shown_width)  # not squeezed: readable at the page's width

    differing = browser.find_elements("css selector", "table.settings tr.differs")
    same = browser.find_elements("css selector", "table.settings tr.same")
    assert differing and same
    names = [row.find_element("css selector", "td").text for row in differing]
    assert "hyperparameters.json: num_epochs" in names and "reward_function.py" in names
    marked = differing[0].find_elements("css selector", "td")
    assert all(cell.value_of_css_property("background-color") == HIGHLIGHT for cell in marked)
    assert all(row.is_displayed() for row in differing)
    assert not any(row.is_displayed() for row in same)  # at first only what differs

    # The whole page, for people to look at: the window as tall as the page.
    height = browser.execute_script("return document.documentElement.scrollHeight")
    browser.set_window_size(1400, height + 120)
    screenshot = tmp_path / "compare.png"
    assert browser.save_screenshot(str(screenshot)) and screenshot.stat().st_size > 50_000
    kept = request.config.cache.mkdir("compare") / "compare.png"
    shutil.copyfile(screenshot, kept)
    print(f"screenshot kept at {kept}")

    browser.find_element("id", "all-settings").click()
    assert all(row.is_displayed() for row in same + differing)
    assert same[0].find_element("css selector", "td").value_of_css_property("background-color") != HIGHLIGHT
