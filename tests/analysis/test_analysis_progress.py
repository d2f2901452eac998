"""Analysis shows its progress with click's progress bar on stderr: in a log (not a terminal) that is the label once,
never `\\r`-overwritten counters."""

from __future__ import annotations

import numpy as np

from racer.analysis import whatif
from racer.analysis.loading import load_steps
from racer.analysis.sources import open_source
from racer.analysis.track_sections import load_track


def test_reading_and_the_reward_what_if_write_their_labels_once_to_a_log(drfc_single, reinvent_route, tmp_path, capsys):
    files = open_source(str(drfc_single))
    steps = load_steps(files, progress=True)
    reward_file = tmp_path / "constant_reward.py"
    reward_file.write_text("def reward_function(params):\n    return 2.0\n")
    replayed = whatif.replay_reward(steps, load_track(str(reinvent_route)), reward_file)
    captured = capsys.readouterr()
    assert captured.out == ""
    assert "\r" not in captured.err
    lines = [line for line in captured.err.splitlines() if line.strip()]
    assert lines == [
        f"reading {len(files.simtraces)} simtrace files",
        f"reward what-if over {len(replayed)} steps",
    ]
    called = ~steps.loc[replayed.index, "episode_status"].isin(whatif.NOT_CALLED_STATUSES)
    assert called.any() and np.all(replayed[called] == 2.0) and np.all(replayed[~called] == 0.0)


def test_no_progress_writes_nothing(drfc_single, capsys):
    load_steps(open_source(str(drfc_single)), progress=False)
    assert capsys.readouterr().err == ""
