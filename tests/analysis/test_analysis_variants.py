"""Column variants (15/17/18/19), continuous actions, evaluation resets and malformed files."""

from __future__ import annotations

import csv
import io

import numpy as np
import pytest
from click.testing import CliRunner

from racer.analysis import aggregate
from racer.analysis.cli import analyze_command
from racer.analysis.loading import load_steps
from racer.analysis.sources import open_source
from racer.shared.deepracer.simtrace import SIMTRACE_COLUMNS, SimtraceError


def read_rows(path):
    with open(path, newline="") as handle:
        return list(csv.reader(handle))


def write_rows(path, rows):
    path.parent.mkdir(parents=True, exist_ok=True)
    buffer = io.StringIO()
    csv.writer(buffer, lineterminator="\n").writerows(rows)
    path.write_text(buffer.getvalue())
    return path


def with_columns(rows, count):
    """A real file cut or extended to `count` columns (obstacle_crash_counter 0, wall_clock = tstamp + an offset)."""
    out = [list(SIMTRACE_COLUMNS[:count])]
    for row in rows[1:]:
        full = row[:17] + [row[17] if len(row) > 17 else "0", str(1.7e9 + float(row[14]))]
        out.append(full[:count])
    return out


def episode_table(folder):
    return aggregate.episodes(load_steps(open_source(str(folder)), progress=False))


@pytest.mark.parametrize("count", [15, 17, 18, 19])
def test_every_column_variant_parses_with_the_same_episodes(tmp_path, deepracer_data, count):
    source = deepracer_data / "simtrace/drfc1_training_26-iteration.csv"
    rows = read_rows(source)
    reference = episode_table(write_rows(tmp_path / "ref/training-simtrace/26-iteration.csv", rows).parents[1])
    variant = episode_table(
        write_rows(tmp_path / f"v{count}/training-simtrace/26-iteration.csv", with_columns(rows, count)).parents[1]
    )
    assert len(variant) == len(reference) == len({r[0] for r in rows[1:]})
    assert variant["progress_pct"].tolist() == reference["progress_pct"].tolist()
    assert variant["reward"].tolist() == pytest.approx(reference["reward"].tolist())
    assert variant["lap_complete"].sum() == reference["lap_complete"].sum() > 0
    if count >= 17:
        assert variant["time_s"].tolist() == pytest.approx(reference["time_s"].tolist())
        assert variant["status"].tolist() == reference["status"].tolist()
    else:  # 2019 files carry no status: nothing is a prepare row, and unfinished episodes end as "unknown"
        assert set(variant.loc[~variant["lap_complete"], "status"]) == {"unknown"}
        assert (variant["time_s"] >= reference["time_s"] - 1e-9).all()


def test_evaluation_resets_and_penalties(tmp_path, deepracer_data):
    """An off-track reset inserted into a real evaluation lap: the pause rows are counted as one reset and their time
    as penalty; the reset jump is not counted as driven distance."""
    rows = read_rows(deepracer_data / "simtrace/console2022_evaluation_0-iteration.csv")
    header = rows[0]
    status, pause = header.index("episode_status"), header.index("pause_duration")
    lap2 = [i for i, row in enumerate(rows) if row[0] == "1"]
    off = lap2[60]
    rows[off][status] = "off_track"
    rows[off][pause] = "2.0"
    pause_rows = lap2[61:91]
    for i in pause_rows:
        rows[i][status] = "pause"
    folder = write_rows(tmp_path / "e/evaluation-1/evaluation-simtrace/0-iteration.csv", rows).parents[2]
    laps = aggregate.evaluation_laps(episode_table(folder)).set_index("lap")
    expected_penalty_s = sum(float(rows[i][14]) - float(rows[i - 1][14]) for i in pause_rows)
    assert laps.loc[2, "resets"] == 1
    assert laps.loc[2, "off_track"] == 1
    assert laps.loc[2, "penalty_s"] == pytest.approx(expected_penalty_s)
    assert laps.loc[2, "lap_time_s"] == pytest.approx(
        sum(float(rows[i][14]) - float(rows[i - 1][14]) for i in lap2 if rows[i][status] != "prepare")
    )
    assert laps.loc[1, "resets"] == laps.loc[3, "resets"] == 0


def test_resets_count_every_incident_like_deepracers_reset_count(tmp_path, deepracer_data):
    """A put-back without penalty (no pause rows) and the exit that ends a lap both count, as in EvaluationMetrics'
    reset_count = off_track + crashed + immobilized + reversed."""
    rows = read_rows(deepracer_data / "simtrace/console2022_evaluation_0-iteration.csv")
    header = rows[0]
    status = header.index("episode_status")
    lap1 = [i for i, row in enumerate(rows) if row[0] == "0"]
    lap2 = [i for i, row in enumerate(rows) if row[0] == "1"]
    rows[lap1[40]][status] = "off_track"  # put back at once, the lap goes on
    rows[lap1[80]][status] = "reversed"
    del rows[lap2[50] + 1 : lap2[-1] + 1]  # lap 2 ends at its first exit
    rows[lap2[50]][status] = "off_track"
    rows[lap2[50]][header.index("done")] = "True"
    folder = write_rows(tmp_path / "e/evaluation-1/evaluation-simtrace/0-iteration.csv", rows).parents[2]
    laps = aggregate.evaluation_laps(episode_table(folder)).set_index("lap")
    assert laps.loc[1, "resets"] == 2 and laps.loc[1, "penalty_s"] == 0
    assert laps.loc[2, "resets"] == 1 and laps.loc[2, "status"] == "off_track"


def test_continuous_action_files_draw_action_usage(tmp_path, deepracer_data, reinvent_route):
    """Continuous actions ('[steer speed]' strings) are binned by steering and speed; only bins that occur are shown."""
    from racer.analysis import plots
    from racer.analysis.track_sections import load_track

    rows = read_rows(deepracer_data / "simtrace/console2022_training_27-iteration.csv")
    action = rows[0].index("action")
    for row in rows[1:]:
        row[action] = f"[{float(row[5]):.1f} {float(row[6]):.1f}]"
    folder = write_rows(tmp_path / "c/training-simtrace/0-iteration.csv", rows).parents[1]
    steps = load_steps(open_source(str(folder)), progress=False)
    assert steps["action"].str.startswith("[").all()
    path, usage = plots.action_usage(
        steps, steps["closest_waypoint"], load_track(str(reinvent_route)), 6, tmp_path / "actions.png"
    )
    assert path.stat().st_size > 10_000
    assert np.allclose(usage.sum(axis=1), 1.0)
    assert (usage.sum(axis=0) > 0).all()  # no column for a steering/speed bin nobody used
    assert "°" in usage.columns[0] and "m/s" in usage.columns[0]


@pytest.mark.parametrize(
    ("line", "column", "bad"), [(57, "X", "abc"), (1200, "done", "maybe"), (3, "episode_status", "flying")]
)
def test_malformed_csv_names_file_and_line(tmp_path, deepracer_data, line, column, bad):
    rows = read_rows(deepracer_data / "simtrace/console2022_training_27-iteration.csv")
    rows[line - 1][rows[0].index(column)] = bad
    path = write_rows(tmp_path / "m/training-simtrace/27-iteration.csv", rows)
    with pytest.raises(SimtraceError, match=rf"{path}.*line {line}\b"):
        load_steps(open_source(str(tmp_path / "m")), progress=False)
    result = CliRunner().invoke(analyze_command, [str(tmp_path / "m"), "--out", str(tmp_path / "out"), "--no-pictures"])
    assert result.exit_code == 1
    assert str(path) in result.output and f"line {line}" in result.output


def test_truncated_row_names_file_and_line(tmp_path, deepracer_data):
    rows = read_rows(deepracer_data / "simtrace/drfc1_training_0-iteration.csv")
    rows[99] = rows[99][:10]
    path = write_rows(tmp_path / "t/training-simtrace/0-iteration.csv", rows)
    result = CliRunner().invoke(analyze_command, [str(tmp_path / "t"), "--out", str(tmp_path / "out")])
    assert result.exit_code == 1
    assert f"{path}: line 100" in result.output


def test_robomaker_log_gives_the_evaluation_of_the_csv(deepracer_data, console_export):
    """The console's simulation log carries the same steps as SIM_TRACE_LOG lines (fewer decimals)."""
    from_log = aggregate.evaluation_laps(episode_table(deepracer_data / "logs/console2022_evaluation_robomaker.log"))
    from_csv = aggregate.evaluation_laps(episode_table(console_export))
    assert len(from_log) == len(from_csv) == 3
    assert from_log["lap_time_s"].tolist() == pytest.approx(from_csv["lap_time_s"].tolist(), abs=1e-9)
    assert from_log["progress_pct"].tolist() == from_csv["progress_pct"].tolist()


def test_malformed_robomaker_log_line_names_the_log_line(tmp_path, deepracer_data):
    lines = (deepracer_data / "logs/console2022_evaluation_robomaker.log").read_text().splitlines(keepends=True)
    trace_lines = [number for number, line in enumerate(lines, start=1) if "SIM_TRACE_LOG:" in line]
    broken = trace_lines[123]
    lines[broken - 1] = lines[broken - 1].replace(",in_progress,", ",in_progresss,")
    log = tmp_path / "evaluation-robomaker.log"
    log.write_text("".join(lines))
    with pytest.raises(SimtraceError, match=rf"{log}: line {broken}: episode_status"):
        episode_table(log)


def test_reverse_direction_episodes_are_detected_and_replayed_reversed(tmp_path, deepracer_data, reinvent_route):
    """A real lap driven backwards (rows in reverse order, closest_waypoint indexed on the reversed route, as DeepRacer
    logs REVERSE_DIR runs) among forward episodes: only it is marked reversed, and the reward replay tells the
    reward function is_reversed=True exactly on its steps."""
    from racer.analysis import whatif
    from racer.analysis.track_sections import forward_waypoint, load_track, reversed_episodes

    track = load_track(str(reinvent_route))
    backwards = track.reversed()
    rows = read_rows(deepracer_data / "simtrace/drfc1_training_26-iteration.csv")
    header, body = rows[0], rows[1:]
    col = {name: header.index(name) for name in header}
    lap = [r for r in body if r[0] == "530"]
    assert lap[-1][col["episode_status"]] == "lap_complete"
    driven_back = []
    for step, (row, clock) in enumerate(zip(reversed(lap), lap, strict=True), start=1):
        new = list(row)
        new[col["episode"]] = "999"
        new[col["steps"]] = f"{float(step)}"
        new[col["yaw"]] = str((float(row[col["yaw"]]) + 360) % 360 - 180)
        new[col["tstamp"]] = str(float(clock[col["tstamp"]]) + 10_000)
        new[col["episode_status"]] = "prepare" if step == 1 else "in_progress"
        x, y = float(row[col["X"]]), float(row[col["Y"]])
        new[col["closest_waypoint"]] = str(backwards.closest_waypoint_for_simtrace(x, y))
        driven_back.append(new)
    folder = write_rows(tmp_path / "r/training-simtrace/26-iteration.csv", [header, *body, *driven_back]).parents[1]
    steps = load_steps(open_source(str(folder)), progress=False)

    verdict = reversed_episodes(steps, track)
    assert verdict.sum() == 1
    assert verdict.xs(999, level="episode").all()
    # In the route file's order, the backwards lap visits the same waypoints as the forward one.
    waypoints = forward_waypoint(steps, verdict, track)
    forward_lap = waypoints[steps["episode"] == 530].to_numpy()
    backward_lap = waypoints[steps["episode"] == 999].to_numpy()[::-1]
    assert np.mean(forward_lap == backward_lap) > 0.9

    reward_file = tmp_path / "reward_function.py"
    reward_file.write_text("def reward_function(params):\n    return 1.0 if params['is_reversed'] else 0.5\n")
    new_reward = whatif.replay_reward(steps, track, reward_file, reversed_by_episode=verdict, show_progress=False)
    running = steps["episode_status"] != "prepare"
    assert (new_reward[running & (steps["episode"] == 999)] == 1.0).all()
    assert (new_reward[running & (steps["episode"] != 999)] == 0.5).all()


def test_simtraces_written_by_racer_itself(tmp_path, deepracer_data, read_csv_episodes):
    """racer's rollout workers write 19 columns with the shared SimtraceWriter into <prefix>/<worker>/training-simtrace:
    the same real steps re-written that way give the same episodes."""
    from racer.shared.deepracer.simtrace import SimtraceWriter, read_simtrace

    source = deepracer_data / "simtrace/drfc1_training_26-iteration.csv"
    writer = SimtraceWriter()
    for row in read_simtrace(source).to_dict(orient="records"):
        writer.add_row({**row, "obstacle_crash_counter": 0, "wall_clock": 1.7e9 + row["tstamp"]})
    prefix = tmp_path / "racer-model"
    for worker in (0, 1):
        target = prefix / str(worker) / "training-simtrace/26-iteration.csv"
        target.parent.mkdir(parents=True)
        target.write_bytes(writer.to_bytes())
    assert target.read_text().splitlines()[0] == ",".join(SIMTRACE_COLUMNS)
    episodes = episode_table(prefix)
    expected = read_csv_episodes(source)
    for worker in (0, 1):
        mine = episodes[episodes["worker"] == worker].set_index("episode")
        assert sorted(mine.index) == sorted(expected)
        assert mine["lap_complete"].sum() == sum(e.complete for e in expected.values())
        assert mine["lap_time_s"].min() == pytest.approx(min(e.time_s for e in expected.values() if e.complete))


def test_continuous_actions_get_their_distributions_drawn(tmp_path, deepracer_data):
    """Continuous models (PPO or SAC) log '[steer speed]': steering and speed histograms over training, drawn even
    without a track; discrete files do not get the picture."""
    from racer.analysis import action_distributions

    rows = read_rows(deepracer_data / "simtrace/console2022_training_27-iteration.csv")
    action = rows[0].index("action")
    rng = np.random.default_rng(0)
    for row in rows[1:]:
        steer, speed = rng.uniform(-30, 30), rng.uniform(1, 2)
        row[5], row[6], row[action] = f"{steer:.2f}", f"{speed:.2f}", f"[{steer:.2f} {speed:.2f}]"
    folder = write_rows(tmp_path / "c/training-simtrace/0-iteration.csv", rows).parents[1]
    write_rows(folder / "training-simtrace/1-iteration.csv", rows)
    steps = load_steps(open_source(str(folder)), progress=False)
    assert action_distributions.is_continuous(steps)
    path = action_distributions.action_distributions(steps, tmp_path / "distributions.png")
    assert path.stat().st_size > 10_000

    result = CliRunner().invoke(analyze_command, [str(folder), "--out", str(tmp_path / "out")])
    assert result.exit_code == 0, result.output
    assert (tmp_path / "out" / "action_distributions.png").is_file()
    assert "Continuous actions" in (tmp_path / "out" / "report.html").read_text()
    discrete = load_steps(
        open_source(str(deepracer_data / "simtrace/console2022_training_27-iteration.csv")), progress=False
    )
    assert not action_distributions.is_continuous(discrete)
