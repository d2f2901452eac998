"""run.env / system.env read as DRfC's activate.sh reads them, worker-N.env as its prepare-config.py does."""

from __future__ import annotations

from pathlib import Path

import pytest

from racer.drfc.shell_env import DrfcFileError, read_shell_env
from racer.drfc.worker_env import read_worker_env


def shell_values(tmp_path: Path, text: str, defined: dict[str, str] | None = None) -> tuple[dict[str, str], list[str]]:
    path = tmp_path / "run.env"
    path.write_text(text)
    file = read_shell_env(path, defined or {})
    return {a.name: a.value for a in file.assignments}, list(file.notes)


def test_references_resolve_to_earlier_lines_and_earlier_files(tmp_path):
    values, notes = shell_values(
        tmp_path,
        "DR_CAR_NAME=FastCar\n"
        "DR_DISPLAY_NAME=$DR_CAR_NAME\n"
        "DR_RACER_NAME=${DR_CAR_NAME}-2\n"
        "DR_LOCAL_S3_REWARD_KEY=$DR_LOCAL_S3_CUSTOM_FILES_PREFIX/reward_function.py\n"
        "DR_X=${DR_UNSET:-fallback}\n"
        "DR_Y=${DR_EMPTY-kept}\n"
        "DR_EMPTY=\n"
        "DR_Z=${DR_EMPTY-notused}${DR_EMPTY:-used}\n",
        defined={"DR_LOCAL_S3_CUSTOM_FILES_PREFIX": "custom_files", "DR_EMPTY": "x"},
    )
    assert values["DR_DISPLAY_NAME"] == "FastCar"
    assert values["DR_RACER_NAME"] == "FastCar-2"
    assert values["DR_LOCAL_S3_REWARD_KEY"] == "custom_files/reward_function.py"
    assert values["DR_X"] == "fallback"
    assert values["DR_Y"] == "x"  # set (by an earlier file) when the line is read
    assert values["DR_EMPTY"] == ""
    assert values["DR_Z"] == "used"
    assert notes == []


def test_an_unset_reference_is_empty_and_said(tmp_path):
    values, notes = shell_values(tmp_path, "DR_MOUNT=$HOME/data\n")
    assert values["DR_MOUNT"] == "/data"
    assert len(notes) == 1 and "run.env:1" in notes[0] and "$HOME" in notes[0]


def test_quotes_escapes_export_and_comments(tmp_path):
    values, notes = shell_values(
        tmp_path,
        "# a comment\n"
        "   # an indented comment\n"
        "\n"
        'DR_OA_OBJECT_POSITIONS="0.23,-1;0.46,1"\n'
        "DR_A='$DR_OA_OBJECT_POSITIONS'\n"
        'DR_B="pre-$DR_A-\\$x"\n'
        "DR_C=a\\;b\n"
        "export DR_WORKERS=3\n"
        "DR_D=plain   # trailing comment\n"
        "#DR_E=commented out\n",
    )
    assert values == {
        "DR_OA_OBJECT_POSITIONS": "0.23,-1;0.46,1",
        "DR_A": "$DR_OA_OBJECT_POSITIONS",
        "DR_B": "pre-$DR_OA_OBJECT_POSITIONS-$x",
        "DR_C": "a;b",
        "DR_WORKERS": "3",
        "DR_D": "plain",
    }
    assert notes == []


def test_a_second_equals_sign_cuts_the_value_as_activate_sh_does(tmp_path):
    values, notes = shell_values(tmp_path, "DR_REMOTE_MINIO_URL=http://nas:9000/?a=b\n")
    assert values["DR_REMOTE_MINIO_URL"] == "http://nas:9000/?a"
    assert len(notes) == 1 and "run.env:1" in notes[0] and "cut -f2" in notes[0]


def test_init_sh_placeholders_stay_unset_in_one_note(tmp_path):
    values, notes = shell_values(tmp_path, "DR_CLOUD=<CLOUD_REPLACE>\nDR_WORKERS=1\nDR_DOCKER_STYLE=<DOCKER_STYLE>\n")
    assert values == {"DR_WORKERS": "1"}
    assert len(notes) == 1 and "DR_CLOUD (line 1)" in notes[0] and "DR_DOCKER_STYLE (line 3)" in notes[0]


@pytest.mark.parametrize(
    ("line", "problem"),
    [
        ("DR_OA_OBJECT_POSITIONS=0.23,-1;0.46,1", "unquoted ';'"),
        ('DR_DISPLAY_NAME="My Car"', "white space inside the line"),
        ("DR_X=$(whoami)", "command substitution"),
        ("DR_X=`whoami`", "command substitution"),
        ('DR_X="open', "not closed"),
        ("DR_X='open", "not closed"),
        ("DR_X=${DR_Y", "not closed"),
        ("DR_X=${DR_Y/a/b}", "racer reads"),
        ("DR_X=$1", "parameter of a running shell"),
        ("DR_X", "not NAME=VALUE"),
        ("1DR=x", "not a shell variable name"),
        ("DR_X=a|b", "unquoted '|'"),
    ],
)
def test_a_malformed_line_names_the_file_and_line(tmp_path, line, problem):
    path = tmp_path / "system.env"
    path.write_text(f"DR_WORKERS=1\n# comment\n{line}\nDR_HOST_X=False\n")
    with pytest.raises(DrfcFileError) as caught:
        read_shell_env(path, {})
    assert str(caught.value).startswith(f"{path}:3: ")
    assert problem in str(caught.value)


def test_worker_env_values_are_taken_as_they_are(tmp_path):
    path = tmp_path / "worker-2.env"
    path.write_text(
        "# worker 2\n"
        "DR_WORLD_NAME=reInvent2019_track\n"
        "\n"
        "  # indented comment\n"
        'DR_OA_OBJECT_POSITIONS="0.2,1;0.5,-1"\n'
        "DR_OA_OBSTACLE_TYPE=box_obstacle\n"
    )
    file = read_worker_env(path)
    assert [(a.name, a.value, a.line) for a in file.assignments] == [
        ("DR_WORLD_NAME", "reInvent2019_track", 2),
        ("DR_OA_OBJECT_POSITIONS", '"0.2,1;0.5,-1"', 5),  # prepare-config.py removes these quotes later
        ("DR_OA_OBSTACLE_TYPE", "box_obstacle", 6),
    ]


@pytest.mark.parametrize(
    ("line", "problem"),
    [
        ("DR_WORLD_NAME", "exactly one NAME=VALUE"),
        ("DR_X=a=b", "exactly one NAME=VALUE"),
        ("export DR_WORLD_NAME=Oval_track", "a variable named 'export DR_WORLD_NAME'"),
        ('DR_WORLD_NAME="Oval_track"', "quotes"),
        ("DR_OA_OBJECT_POSITIONS='0.2,1'", "quotes"),
        ("DR_WORLD_NAME=Oval_track ", "white space around the value"),
        ("DR_CAR_COLOR=$DR_COLOUR", "does not expand"),
    ],
)
def test_a_worker_env_line_prepare_config_would_misread_names_the_file_and_line(tmp_path, line, problem):
    path = tmp_path / "worker-3.env"
    path.write_text(f"DR_RACE_TYPE=TIME_TRIAL\n{line}\n")
    with pytest.raises(DrfcFileError) as caught:
        read_worker_env(path)
    assert str(caught.value).startswith(f"{path}:2: ")
    assert problem in str(caught.value)
