"""Object-avoidance runs: crashes counted per episode and iteration, fixed obstacles drawn on the track maps."""

from __future__ import annotations

import csv
import io
from collections import Counter, defaultdict

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner
from PIL import Image

from racer.analysis.cli import analyze_command
from racer.analysis.obstacle_layout import obstacle_layout
from racer.shared.deepracer.simtrace import SIMTRACE_COLUMNS
from racer.shared.sim.objects.poses import ObjectKind
from racer.shared.sim.tracks.track import Track

OA_PARAMS = """WORLD_NAME: "reinvent_base"
RACE_TYPE: "OBJECT_AVOIDANCE"
NUMBER_OF_OBSTACLES: "3"
OBJECT_POSITIONS: ["0.25,1", "0.5,-1", "0.75,1"]
"""
BOX_BROWN = np.array([0x7B, 0x61, 0x4F])


def _crashed_copy(rows: list[list[str]], every: int) -> tuple[list[list[str]], Counter, dict]:
    """The real rows as a 19-column file in which every `every`-th episode ends `crashed` instead of its own status;
    each crashed episode's obstacle_crash_counter counts up to 2 on its last rows. Returns the crash counts."""
    header = rows[0]
    status, done = header.index("episode_status"), header.index("done")
    last_row = {}
    for index, row in enumerate(rows[1:], start=1):
        last_row[row[0]] = index
    crashed = Counter()
    counter_max = defaultdict(int)
    out = [list(SIMTRACE_COLUMNS)]
    chosen = {episode for n, episode in enumerate(sorted(last_row, key=int)) if n % every == 0}
    for index, row in enumerate(rows[1:], start=1):
        new = row[:17] + ["0", str(1.7e9 + float(row[14]))]
        if row[0] in chosen and index == last_row[row[0]]:
            new[status], new[done] = "crashed", "True"
            crashed[row[0]] += 1
        if row[0] in chosen and index >= last_row[row[0]] - 1:
            new[17] = "2" if index == last_row[row[0]] else "1"
            counter_max[row[0]] = 2
        out.append(new)
    return out, crashed, counter_max


def _write(path, rows) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    buffer = io.StringIO()
    csv.writer(buffer, lineterminator="\n").writerows(rows)
    path.write_text(buffer.getvalue())


@pytest.fixture
def oa_run(tmp_path, deepracer_data):
    """A racer-layout object-avoidance run: two real DRfC iterations with crashes put in, and its params yaml."""
    root = tmp_path / "oa-model"
    expected = {}
    for iteration, every in ((0, 3), (26, 5)):
        with open(deepracer_data / f"simtrace/drfc1_training_{iteration}-iteration.csv", newline="") as handle:
            rows = list(csv.reader(handle))
        changed, crashed, counter_max = _crashed_copy(rows, every)
        _write(root / f"training-simtrace/{iteration}-iteration.csv", changed)
        expected[iteration] = (crashed, counter_max, len({row[0] for row in rows[1:]}))
    (root / "training_params.yaml").write_text(OA_PARAMS)
    return root, expected


def _brown_pixels(path) -> int:
    pixels = np.asarray(Image.open(path).convert("RGB")).reshape(-1, 3).astype(int)
    return int((np.abs(pixels - BOX_BROWN).sum(axis=1) < 12).sum())


def test_crashes_per_episode_and_iteration_in_tables_and_report(oa_run, tmp_path, deepracer_data):
    root, expected = oa_run
    out = tmp_path / "report"
    result = CliRunner().invoke(
        analyze_command, [str(root), "--track", str(deepracer_data / "routes/reinvent_base.npy"), "--out", str(out)]
    )
    assert result.exit_code == 0, result.output

    episodes = pd.read_csv(out / "episodes.csv")
    iterations = pd.read_csv(out / "iterations.csv")
    for iteration, (crashed, counter_max, episode_count) in expected.items():
        mine = episodes[episodes["iteration"] == iteration].set_index("episode")
        assert len(mine) == episode_count
        assert {str(e): int(n) for e, n in mine["crashed"].items() if n} == dict(crashed)
        assert {str(e): int(n) for e, n in mine["obstacle_crash_counter"].items() if n} == dict(counter_max)
        assert set(mine.loc[[int(e) for e in crashed], "status"]) == {"crashed"}
        row = iterations[iterations["iteration"] == iteration].iloc[0]
        assert row["crashes"] == sum(crashed.values()) > 0
        assert row["crashed_episodes"] == len(crashed)

    html = (out / "report.html").read_text()
    assert "Crashes by iteration" in html and "crashed_episodes_pct" in html
    # The three boxes are drawn (in the SimApp's brown) on the crash map and the lap maps.
    assert _brown_pixels(out / "crashes.png") > 200
    assert _brown_pixels(out / "best_laps.png") > 200


@pytest.mark.slow
def test_a_time_trial_report_has_no_crash_section(tmp_path, deepracer_data):
    root = tmp_path / "tt-model"
    with open(deepracer_data / "simtrace/drfc1_training_0-iteration.csv", newline="") as handle:
        _write(root / "training-simtrace/0-iteration.csv", list(csv.reader(handle)))
    out = tmp_path / "report"
    result = CliRunner().invoke(
        analyze_command, [str(root), "--track", str(deepracer_data / "routes/reinvent_base.npy"), "--out", str(out)]
    )
    assert result.exit_code == 0, result.output
    assert not (out / "crashes.png").exists()
    assert "Crashes by iteration" not in (out / "report.html").read_text()
    assert _brown_pixels(out / "best_laps.png") < 20  # a few antialiased path pixels at most
    assert pd.read_csv(out / "iterations.csv")["crashes"].eq(0).all()


def test_layout_places_fixed_positions_on_their_lanes(deepracer_data):
    track = Track.load(deepracer_data / "routes/reinvent_base.npy")
    layout = obstacle_layout({"training_params.yaml": OA_PARAMS.encode()}, track)
    assert layout.race_type == "OBJECT_AVOIDANCE" and layout.notes == (
        "OBJECT_AVOIDANCE: 3 fixed obstacles from training_params.yaml drawn on the track maps.",
    )
    assert [obj.kind for obj in layout.obstacles] == [ObjectKind.BOX_OBSTACLE] * 3
    for obj, (ndist, lane) in zip(layout.obstacles, ((0.25, "inner"), (0.5, "outer"), (0.75, "inner")), strict=True):
        assert (obj.x_m, obj.y_m, obj.yaw_rad) == pytest.approx(track.pose_at(ndist, lane))


def test_layout_notes_what_it_cannot_draw(deepracer_data):
    track = Track.load(deepracer_data / "routes/reinvent_base.npy")
    randomised = obstacle_layout(
        {
            "training_params.yaml": b'RACE_TYPE: OBJECT_AVOIDANCE\nNUMBER_OF_OBSTACLES: "4"\nRANDOMIZE_OBSTACLE_LOCATIONS: "true"\n'
        },
        track,
    )
    assert randomised.obstacles == () and "RANDOMIZE_OBSTACLE_LOCATIONS" in randomised.notes[0]
    bad = obstacle_layout({"training_params_1.yaml": b'NUMBER_OF_OBSTACLES: "three"\n'}, track)
    assert bad.obstacles == () and "training_params_1.yaml" in bad.notes[0] and "NUMBER_OF_OBSTACLES" in bad.notes[0]
    assert obstacle_layout({}, track).obstacles == ()
    bots = obstacle_layout({"training_params.yaml": b'RACE_TYPE: HEAD_TO_BOT\nNUMBER_OF_BOT_CARS: "2"\n'}, track)
    assert bots.race_type == "HEAD_TO_BOT" and bots.obstacles == () and "2 bot cars" in bots.notes[0]
