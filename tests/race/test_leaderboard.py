"""The board files from hand-made results: CSV under DRoA's names, the HTML table, videos, map and sector times."""

from __future__ import annotations

import numpy as np

from racer.race.html_report import write_html
from racer.race.lap_trace import sector_times
from racer.race.leaderboard import board_json, standings_from_results, write_board
from racer.race.race_file import parse_race
from racer.shared.sim.tracks.track import Track


def test_board_files_and_page(tmp_path):
    race = parse_race(
        {
            "trackConfig": {"trackId": "racer_oval"},
            "raceType": "TIME_TRIAL",
            "timingMethod": "BEST_LAP_TIME",
            "submissionTerminationConditions": {"minimumLaps": 1, "maximumLaps": 1},
        },
        "demo.yaml",
        "demo",
    )
    track = Track.load("racer_oval")
    centre = (track.inner_border + track.outer_border) / 2
    trace = {
        "lap": 1,
        "lap_time_s": 9.5,
        "x": centre[:, 0].tolist(),
        "y": centre[:, 1].tolist(),
        "speed_mps": np.linspace(1, 3, len(centre)).tolist(),
        "sector_times_s": sector_times([0, 40, 70, 100], [0, 3, 6, 9.5], 0.0),
    }
    assert trace["sector_times_s"] == [3.0, 3.0, 3.5]
    assert sector_times([0, 40, 60], [0, 3, 6], 0.0) == [3.0, None, None]
    results = [
        {
            "entrant": "fast",
            "metrics": [{"completion_percentage": 100, "elapsed_time_in_milliseconds": 9500, "reset_count": 0}],
            "best_lap": trace,
            "videos": {"camera-incar": "fast-camera-incar.mp4"},
        },
        {"entrant": "broken", "reason": "racer model import failed: x", "code": "COACH_CHECKPOINT_DOES_NOT_EXIST"},
    ]
    standings = standings_from_results(race, results)
    paths = write_board(tmp_path, race, "racer_oval", 0, standings, results)
    lines = paths["csv"].read_text().splitlines()
    assert lines[0].startswith("rank,entrant,rankingScore,completedLapCount,bestLapTime,avgLapTime,totalLapTime")
    assert lines[1].startswith("1,fast,9500,1,9500,9500,9500,0")
    assert lines[2].startswith(",broken,,") and lines[2].endswith("COACH_CHECKPOINT_DOES_NOT_EXIST")
    page = write_html(tmp_path, race, board_json(race, "racer_oval", 0, standings, results), results).read_text()
    assert 'href="videos/fast-camera-incar.mp4"' in page and "data:image/png;base64," in page
    assert "sector 3" in page and "COACH_CHECKPOINT_DOES_NOT_EXIST" in page
