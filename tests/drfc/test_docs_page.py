"""docs/coming-from-drfc.md and the code agree: every DR_* variable of the table with the same words and uses, and
every dr-* / droa-* command of DRfC beside racer's."""

from __future__ import annotations

import re

from racer.drfc.variables import VARIABLES, Use
from tests.shared_data import REPO_ROOT

PAGE = REPO_ROOT / "docs" / "coming-from-drfc.md"
LABELS = {Use.HONOURED: "yes", Use.NO_EFFECT: "no effect", Use.NOT_HONOURED: "reported", Use.NOT_READ: "not read"}

DRFC_COMMANDS = (
    # deepracer-for-cloud 2eb1a1f1: bin/scripts_wrapper.sh, bin/activate.sh, bin/module/summary.sh, bin/module/droa.sh
    "dr-upload-custom-files", "dr-download-custom-files", "dr-upload-model", "dr-download-model", "dr-upload-car-zip",
    "dr-list-aws-models", "dr-set-upload-model", "dr-increment-upload-model", "dr-start-training",
    "dr-increment-training", "dr-stop-training", "dr-start-evaluation", "dr-stop-evaluation", "dr-stop-all",
    "dr-start-tournament", "dr-start-loganalysis", "dr-stop-loganalysis", "dr-logs-sagemaker", "dr-find-sagemaker",
    "dr-logs-robomaker", "dr-find-robomaker", "dr-get-robomaker-stats", "dr-logs-loganalysis", "dr-url-loganalysis",
    "dr-view-stream", "dr-start-viewer", "dr-stop-viewer", "dr-update-viewer", "dr-start-metrics", "dr-stop-metrics",
    "dr-update-env", "dr-update", "dr-reload", "dr-summary", "dr-local-aws",
    "droa-list-models", "droa-get-model", "droa-download-logs", "droa-delete-model", "droa-import-model",
)  # fmt: skip


def page_rows() -> list[list[str]]:
    rows = []
    for line in PAGE.read_text().splitlines():
        if line.startswith("| "):
            rows.append([cell.strip() for cell in line.strip().strip("|").split(" | ")])
    return rows


def test_the_page_shows_every_variable_as_the_table_has_it():
    shown = {}
    for cells in page_rows():
        match = re.fullmatch(r"`(DR_[A-Z0-9_]+)`", cells[0])
        if match:
            assert match.group(1) not in shown, f"{match.group(1)} twice on the page"
            shown[match.group(1)] = cells[1:]
    expected = {v.name: [LABELS[v.train], LABELS[v.evaluate], v.racer] for v in VARIABLES}
    assert set(shown) == set(expected), (set(expected) - set(shown), set(shown) - set(expected))
    for name, cells in expected.items():
        assert shown[name] == cells, name


def test_the_page_puts_every_drfc_command_beside_racers():
    first_cells = " ".join(cells[0] for cells in page_rows())
    named = set(re.findall(r"`((?:dr|droa)-[a-z-]+)`", first_cells))
    assert named == set(DRFC_COMMANDS), (set(DRFC_COMMANDS) - named, named - set(DRFC_COMMANDS))
    for cells in page_rows():
        if re.match(r"`(dr|droa)-", cells[0]):
            assert len(cells) == 3 and (
                cells[1].startswith(("`racer", "Ctrl-C", "the live page", "`<store>")) or cells[1] == "none"
            )
            assert cells[1] != "none" or cells[2], f"{cells[0]}: say why there is no racer command"


def test_the_page_is_in_the_site_and_the_readme():
    assert "coming-from-drfc.md" in (REPO_ROOT / "mkdocs.yml").read_text()
    assert "(docs/coming-from-drfc.md)" in (REPO_ROOT / "README.md").read_text()
