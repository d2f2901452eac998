"""Simtrace CSV: real files of every variant read with exact row counts, writer reproduces real rows byte-for-byte."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from racer.shared.deepracer.episode_status import EpisodeStatus
from racer.shared.deepracer.simtrace import (
    SIMTRACE_COLUMNS,
    SimtraceError,
    SimtraceWriter,
    format_continuous_action,
    format_simtrace_row,
    format_simtrace_value,
    parse_simtrace_action,
    read_simtrace,
    read_simtrace_lines,
)
from racer.shared.deepracer.simtrace import _read_with_pandas as read_fast


def real_simtraces(data_dir):
    files = sorted((data_dir / "simtrace").glob("*.csv"))
    assert len(files) >= 8, files
    return files


def data_lines(path):
    """The file's lines without the header, counted independently of the reader."""
    text = path.read_text()
    assert text.endswith("\n")
    return text[:-1].split("\n")[1:]


def test_column_names():
    assert len(SIMTRACE_COLUMNS) == 19
    assert SIMTRACE_COLUMNS[:3] == ("episode", "steps", "X")
    assert SIMTRACE_COLUMNS[14:] == (
        "tstamp",
        "episode_status",
        "pause_duration",
        "obstacle_crash_counter",
        "wall_clock",
    )


def test_episode_status_labels():
    assert EpisodeStatus.LAP_COMPLETE.label == "Lap complete"
    assert EpisodeStatus.OFF_TRACK.label == "Off track"
    assert EpisodeStatus.IN_PROGRESS.label == "In progress"
    assert EpisodeStatus.TIME_UP.label == "Time Up"
    assert EpisodeStatus("immobilized") is EpisodeStatus.IMMOBILIZED
    assert EpisodeStatus.from_label("Crashed") is EpisodeStatus.CRASHED
    assert str(EpisodeStatus.PAUSE) == "pause"
    assert EpisodeStatus.OFF_TRACK.ends_episode and not EpisodeStatus.PAUSE.ends_episode
    with pytest.raises(ValueError, match="allowed: Prepare, In progress"):
        EpisodeStatus.from_label("Finished")


def test_every_real_simtrace_reads_with_exact_rows_and_types(deepracer_data):
    widths = set()
    for path in real_simtraces(deepracer_data):
        lines = data_lines(path)
        header = path.read_text().split("\n", 1)[0].split(",")
        widths.add(len(header))
        frame = read_simtrace(path)
        assert len(frame) == len(lines), path.name
        assert list(frame.columns) == header
        assert frame["episode"].dtype == np.int64 and frame["closest_waypoint"].dtype == np.int64
        assert frame["done"].dtype == bool and frame["all_wheels_on_track"].dtype == bool
        assert frame["action"].dtype == np.int64
        for column in ("steps", "X", "Y", "yaw", "steer", "throttle", "reward", "progress", "track_len", "tstamp"):
            assert frame[column].dtype == np.float64, (path.name, column)
        # spot-check values against the raw text of the first and last rows
        for position in (0, len(lines) - 1):
            fields = lines[position].split(",")
            assert frame["X"].iloc[position] == float(fields[2])
            assert frame["done"].iloc[position] == (fields[9] == "True")
            assert frame["episode_status"].iloc[position] == fields[15]
        assert int(frame["done"].sum()) == sum(line.split(",")[9] == "True" for line in lines)
        assert set(frame["episode_status"]) <= {status.value for status in EpisodeStatus}
    # 17 columns (to pause_duration), 18 (+ obstacle_crash_counter) and DeepRacer on AWS's 19 (+ wall_clock)
    assert widths == {17, 18, 19}


def assert_same_frame(fast: pd.DataFrame, lines: pd.DataFrame, name: str) -> None:
    """Every field of both readings equal, float bits included (repr round-trips exactly)."""
    assert list(fast.columns) == list(lines.columns) and len(fast) == len(lines), name
    for column in fast.columns:
        assert fast[column].dtype == lines[column].dtype, (name, column)
        assert [repr(v) for v in fast[column].tolist()] == [repr(v) for v in lines[column].tolist()], (name, column)
    pd.testing.assert_frame_equal(fast, lines, check_exact=True)


def test_every_real_simtrace_reads_the_same_with_pandas_and_the_line_parser(deepracer_data):
    """The fast path reads every real file itself (no fall-back) and gives what the line parser gives, field for
    field, and every float is Python's float() of the file's text."""
    for path in real_simtraces(deepracer_data):
        raw = path.read_bytes()
        fast = read_fast(raw)
        assert fast is not None, f"{path.name}: pandas' path gave up on a real file"
        lines = read_simtrace_lines(raw, str(path))
        assert_same_frame(fast, lines, path.name)
        assert_same_frame(read_simtrace(path), lines, path.name)
        texts = [line.split(",") for line in data_lines(path)]
        assert fast["tstamp"].tolist() == [float(fields[14]) for fields in texts], path.name


def test_a_continuous_simtrace_reads_the_same_with_pandas_and_the_line_parser():
    writer = SimtraceWriter()
    for step in range(5):
        steering, speed = -30.0 + step * 7.123456789, 0.5 + step / 3
        writer.add_row({**full_row(), "steps": float(step + 1), "steer": steering, "throttle": speed,
                        "action": [steering, speed]})  # fmt: skip
    raw = writer.to_bytes()
    fast = read_fast(raw)
    assert fast is not None and fast["action"].iloc[1] == "[-22.876543211 0.8333333333333333]"
    assert_same_frame(fast, read_simtrace_lines(raw, "cont.csv"), "cont.csv")


def test_real_18_column_file_has_obstacle_crash_counter(deepracer_data):
    frame = read_simtrace(deepracer_data / "simtrace" / "drfc1_evaluation_0-iteration.csv")
    assert frame.columns[-1] == "obstacle_crash_counter"
    assert frame["obstacle_crash_counter"].dtype == np.int64


def typed_row(frame, position, original_line):
    row = frame.iloc[position].to_dict()
    if original_line.split(",")[11] == "100":
        row["progress"] = 100  # the SimApp caps with min(p, 100), which yields the int 100
    return row


def test_writer_formatting_matches_every_real_row_byte_for_byte(deepracer_data):
    for path in real_simtraces(deepracer_data):
        lines = data_lines(path)
        frame = read_simtrace(path)
        records = frame.to_dict("records")
        for position, (record, line) in enumerate(zip(records, lines, strict=True)):
            if line.split(",")[11] == "100":
                record["progress"] = 100
            assert format_simtrace_row(record) == line, (path.name, position + 2)


def test_writer_bytes_equal_a_real_file_written_with_its_own_column_count(deepracer_data):
    path = deepracer_data / "simtrace" / "drfc1_evaluation_0-iteration.csv"
    frame = read_simtrace(path)
    lines = data_lines(path)
    writer = SimtraceWriter(num_columns=18)
    for position in range(len(frame)):
        writer.add_row(typed_row(frame, position, lines[position]))
    assert writer.to_bytes() == path.read_bytes()


def full_row(**changes):
    row = {
        "episode": 3,
        "steps": 12.0,
        "X": 3.1997327938476117,
        "Y": 0.6831032114197831,
        "yaw": 0.18326595495146542,
        "steer": 9.999999999999998,
        "throttle": 2.0,
        "action": 9,
        "reward": 0.001,
        "done": False,
        "all_wheels_on_track": True,
        "progress": 11.860182015921922,
        "closest_waypoint": 8,
        "track_len": 17.709159380834848,
        "tstamp": 56.002,
        "episode_status": EpisodeStatus.IN_PROGRESS,
        "pause_duration": 0.0,
        "obstacle_crash_counter": 0,
        "wall_clock": 1772906130.6636426,
    }
    row.update(changes)
    return row


def test_round_trip_19_columns_discrete():
    writer = SimtraceWriter()
    rows = [
        full_row(steps=1.0, reward=0.0, episode_status=EpisodeStatus.PREPARE),
        full_row(),
        full_row(steps=13.0, done=True, all_wheels_on_track=False, episode_status="off_track", reward=1e-3),
        full_row(episode=4, progress=100, episode_status=EpisodeStatus.LAP_COMPLETE, done=True),
    ]
    writer.extend(rows)
    assert len(writer) == 4
    data = writer.to_bytes()
    text = data.decode()
    assert text.splitlines()[0] == ",".join(SIMTRACE_COLUMNS)
    assert text.endswith("\n") and text.count("\n") == 5
    assert text.splitlines()[4].split(",")[11] == "100"
    frame = read_simtrace(data)
    assert list(frame.columns) == list(SIMTRACE_COLUMNS)
    assert len(frame) == 4
    assert frame["wall_clock"].iloc[0] == 1772906130.6636426
    assert frame["episode_status"].tolist() == ["prepare", "in_progress", "off_track", "lap_complete"]
    assert frame["done"].tolist() == [False, False, True, True]
    assert frame["obstacle_crash_counter"].dtype == np.int64
    for position, row in enumerate(rows):
        for name in SIMTRACE_COLUMNS:
            assert frame[name].iloc[position] == row[name], (position, name)


def test_round_trip_continuous_action():
    writer = SimtraceWriter(num_columns=17)
    base = {name: value for name, value in full_row().items() if name in SIMTRACE_COLUMNS[:17]}
    writer.add_row({**base, "steer": -12.345678912345, "throttle": 1.5, "action": np.array([-12.345678912345, 1.5])})
    writer.add_row({**base, "steer": -30.0, "throttle": 1.0, "action": [-30.0, 1.0]})
    text = writer.to_bytes().decode()
    assert text.splitlines()[1].split(",")[7] == "[-12.345678912345 1.5]"
    assert text.splitlines()[2].split(",")[7] == "[-30.0 1.0]"
    frame = read_simtrace(writer.to_bytes(), source="cont.csv")
    assert frame["action"].tolist() == ["[-12.345678912345 1.5]", "[-30.0 1.0]"]
    assert parse_simtrace_action(frame["action"].iloc[1]) == (-30.0, 1.0)
    assert parse_simtrace_action("7") == 7


def test_continuous_action_is_written_as_the_simapp_formats_it():
    """agent_ctrl/utils.py: `"[{} {}]".format(action[0], action[1])` on the scaled float64 action array."""
    rng = np.random.default_rng(0)
    samples = [np.array([-25.0, 1.6248216569843206]), np.array([30.0, 4.0]), np.array([0.0, 0.5])]
    samples += [np.array([rng.uniform(-30, 30), rng.uniform(0.5, 4)]) for _ in range(200)]
    for action in samples:
        field = format_continuous_action(action)
        assert field == f"[{action[0]} {action[1]}]"
        steer_text, speed_text = field[1:-1].split(" ")  # scripts split on one space
        assert (float(steer_text), float(speed_text)) == (action[0], action[1])
    assert format_continuous_action([-25.0, 1.6248216569843206]) == "[-25.0 1.6248216569843206]"


def test_15_column_variant_reads():
    writer = SimtraceWriter(num_columns=15)
    row = {name: value for name, value in full_row().items() if name in SIMTRACE_COLUMNS[:15]}
    writer.add_row(row)
    writer.add_row({**row, "steps": 13.0})
    frame = read_simtrace(writer.to_bytes())
    assert list(frame.columns) == list(SIMTRACE_COLUMNS[:15])
    assert frame["steps"].tolist() == [12.0, 13.0]


def test_value_formatting():
    assert format_simtrace_value(True) == "True"
    assert format_simtrace_value(np.bool_(False)) == "False"
    assert format_simtrace_value(1.0) == "1.0"
    assert format_simtrace_value(np.float64(0.1)) == "0.1"
    assert format_simtrace_value(np.int64(12)) == "12"
    assert format_simtrace_value(100) == "100"
    assert format_simtrace_value(EpisodeStatus.OFF_TRACK) == "off_track"
    with pytest.raises(ValueError, match="comma"):
        format_simtrace_value("a,b")
    with pytest.raises(TypeError):
        format_simtrace_value({"a": 1})
    with pytest.raises(ValueError, match="2 values"):
        format_simtrace_value([1.0, 2.0, 3.0])


def test_writer_rejects_bad_rows():
    writer = SimtraceWriter()
    with pytest.raises(ValueError, match=r"missing columns \['wall_clock'\]"):
        writer.add_row({name: value for name, value in full_row().items() if name != "wall_clock"})
    with pytest.raises(ValueError, match="done must be a bool"):
        writer.add_row(full_row(done="False"))
    with pytest.raises(ValueError, match="episode_status 'finished'"):
        writer.add_row(full_row(episode_status="finished"))
    with pytest.raises(ValueError, match="num_columns 16"):
        SimtraceWriter(num_columns=16)
    with pytest.raises(ValueError, match="first 15, 17, 18 or 19"):
        format_simtrace_row({"episode": 1})
    assert len(writer) == 0
    writer.add_row(full_row())
    writer.clear()
    assert writer.to_bytes() == (",".join(SIMTRACE_COLUMNS) + "\n").encode()


HEADER17 = ",".join(SIMTRACE_COLUMNS[:17])
GOOD17 = "0,1.0,3.2,0.68,0.18,-30.0,1.0,0,0.0,False,True,0.79,1,17.7,6.211,prepare,0.0"


def replace_field(line, index, value):
    fields = line.split(",")
    fields[index] = value
    return ",".join(fields)


MALFORMED = [
    # (data lines after the header, line number named, words)
    ([GOOD17, "0,2.0,3.2"], 3, "3 fields, the header has 17"),
    ([GOOD17, GOOD17 + ",0"], 3, "18 fields, the header has 17"),
    ([GOOD17, replace_field(GOOD17, 2, "abc")], 3, "X: 'abc' is not a number"),
    ([replace_field(GOOD17, 0, "1.5")], 2, "episode: '1.5' is not an integer"),
    ([GOOD17, GOOD17, replace_field(GOOD17, 9, "true")], 4, "done: 'true' is not True or False"),
    ([replace_field(GOOD17, 15, "finished")], 2, "episode_status: 'finished' is not one of prepare"),
    ([replace_field(GOOD17, 7, "left")], 2, "action: 'left' is not"),
    ([GOOD17, replace_field(GOOD17, 7, "[1.0 2.0]")], 3, "action: '[1.0 2.0]'"),
    ([GOOD17, ""], 3, "1 fields"),
    ([replace_field(GOOD17, 12, "")], 2, "closest_waypoint: '' is not an integer"),
]


@pytest.mark.parametrize(("rows", "line_number", "words"), MALFORMED)
def test_malformed_csv_names_file_and_line(rows, line_number, words):
    data = ("\n".join([HEADER17, *rows]) + "\n").encode()
    try:  # pandas' path does not return a frame for it: it raises, or gives up, and the line parser names the line
        assert read_fast(data) is None
    except (ValueError, TypeError):
        pass
    with pytest.raises(SimtraceError) as caught:
        read_simtrace(data, source="training-simtrace/0-iteration.csv")
    message = str(caught.value)
    assert message.startswith(f"training-simtrace/0-iteration.csv: line {line_number}: "), message
    assert words in message, message


@pytest.mark.parametrize(
    "header",
    ["", "episode,steps,x,Y", ",".join(SIMTRACE_COLUMNS[:16]), ",".join(reversed(SIMTRACE_COLUMNS[:17]))],
)
def test_bad_header_names_line_1(header, tmp_path):
    path = tmp_path / "bad.csv"
    path.write_text(header + "\n" if header else "")
    with pytest.raises(SimtraceError, match=f"^{path}: line 1: "):
        read_simtrace(path)


def test_header_only_file_gives_an_empty_typed_frame():
    frame = read_simtrace((HEADER17 + "\n").encode())
    assert len(frame) == 0 and list(frame.columns) == list(SIMTRACE_COLUMNS[:17])
    assert frame["episode"].dtype == np.int64


def test_crlf_and_missing_final_newline_are_accepted():
    frame = read_simtrace(f"{HEADER17}\r\n{GOOD17}\r\n{GOOD17}".encode())
    assert len(frame) == 2 and frame["pause_duration"].tolist() == [0.0, 0.0]


def test_non_utf8_names_the_file():
    with pytest.raises(SimtraceError, match="^x.csv: not UTF-8"):
        read_simtrace(b"\xff\xfe" + HEADER17.encode(), source="x.csv")


def test_a_real_simtrace_with_one_bad_line_names_the_file_and_that_line(deepracer_data, tmp_path):
    path = real_simtraces(deepracer_data)[0]
    lines = path.read_text().split("\n")
    fields = lines[99].split(",")  # line 100 of the file
    fields[3] = "0.12.3"
    lines[99] = ",".join(fields)
    broken = tmp_path / path.name
    broken.write_text("\n".join(lines))
    with pytest.raises(SimtraceError, match=rf"^{broken}: line 100: Y: '0.12.3' is not a number$"):
        read_simtrace(broken)
