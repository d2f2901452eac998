"""Where a DRfC file means one thing to its reader and another to DRfC: each test states DRfC's rule, with its file
and line at deepracer-for-cloud 2eb1a1f, and asserts what racer does beside it. The DRfC outcomes in the docstrings
were seen by running those lines of activate.sh (bash) and prepare-config.py on the same file contents."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from racer.drfc.experiment import read_experiment
from racer.drfc.shell_env import DrfcFileError
from racer.drfc.training import read_training
from racer.drfc.worker_env import read_worker_env
from racer.shared.config import drfc_dir
from tests.drfc.conftest import write_experiment
from tests.drfc.test_experiment import RUN
from tests.drfc.test_options import train_probe

MULTI = f"{RUN}DR_WORKERS=2\n"
"""Two workers, multi-config, every per-worker variable set; 17 lines."""


def test_an_assignment_in_a_trailing_comment_is_applied_with_a_warning(tmp_path):
    """bin/activate.sh:101-105: `grep -v '^#'` drops only lines that start with `#`, `for l in $LINES` splits the
    rest into words, and every word runs as `eval "export NAME=VALUE"`, a trailing comment's words too. So DRfC trains
    this reversed, and later words see earlier ones; a word that starts with `#` is a comment to eval (nothing)."""
    folder = write_experiment(
        tmp_path / "exp",
        "DR_TRAIN_REVERSE_DIRECTION=False # set DR_TRAIN_REVERSE_DIRECTION=True to reverse\n"
        "DR_CAR_NAME=Fast # DR_DISPLAY_NAME=$DR_CAR_NAME-2 #DR_RACER_NAME=never\n",
    )
    training = read_training(folder)
    assert training.worker_params[0]["REVERSE_DIR"] == "True"
    env = training.experiment.env
    assert env["DR_DISPLAY_NAME"].value == "Fast-2" and "DR_RACER_NAME" not in env
    warnings = training.experiment.warnings
    assert len(warnings) == 2
    assert warnings[0].startswith(f"{folder / 'run.env'}:1: 'DR_TRAIN_REVERSE_DIRECTION=True' inside a comment")
    assert warnings[1].startswith(f"{folder / 'run.env'}:2: ")


def test_an_indented_comment_line_is_run_as_well(tmp_path):
    """bin/activate.sh:101: `grep -v '^#'` matches `#` in column 0 only, so `  # DR_WORLD_NAME=Austin` is read and
    its assignment runs (lines 102-105); `#DR_WORLD_NAME=...` in column 0 is dropped, as is an indented `#DR_X=...`
    (eval sees `export #DR_X=...`: a comment). The same loop reads system.env (lines 71-75)."""
    folder = write_experiment(
        tmp_path / "exp",
        "DR_WORLD_NAME=reinvent_base\n#DR_WORLD_NAME=Bowtie_track\n  # DR_WORLD_NAME=Austin\n\t#DR_RACE_TYPE=HEAD_TO_BOT\n",
        system="    # DR_WORKERS=3 workers here\n",
    )
    experiment = read_experiment(folder)
    assert experiment.env["DR_WORLD_NAME"].value == "Austin" and experiment.env["DR_WORLD_NAME"].line == 3
    assert "DR_RACE_TYPE" not in experiment.env
    assert experiment.num_workers == 3
    assert [w.split(": ")[0] for w in experiment.warnings] == [f"{folder}/system.env:1", f"{folder}/run.env:3"]


@pytest.mark.parametrize(
    ("line", "problem"),
    [
        ("DR_WORKERS=1 # see DR_WORLD_NAME", "sets the variable of that name to its own name (DR_WORLD_NAME"),
        ("DR_WORKERS=1 # e.g. DR_OA_OBJECT_POSITIONS=0.2,1;0.5,-1", "unquoted ';'"),
    ],
)
def test_a_comment_word_drfc_would_misread_is_refused(tmp_path, line, problem):
    """bin/activate.sh:103-105: a word without `=` is cut to itself as name and value (`cut` prints a line without
    the delimiter whole), so a DRfC variable named in a comment is set to its own name; a comment's `;` ends the
    eval'd command there, and what follows runs as a command."""
    path = tmp_path / "run.env"
    path.write_text(f"DR_CAR_NAME=a\n{line}\n")
    with pytest.raises(DrfcFileError) as caught:
        read_experiment(path)
    assert str(caught.value).startswith(f"{path}:2: ") and problem in str(caught.value)


def bare_run_env(tmp_path: Path) -> tuple[Path, Path]:
    """A DRfC folder with its system.env, worker-2.env and custom_files/, and a run.env elsewhere with its own."""
    drfc = write_experiment(
        tmp_path / "deepracer-for-cloud",
        MULTI,
        system="DR_LOCAL_S3_BUCKET=drfc\n",
        workers={2: "DR_WORLD_NAME=Oval_track\n"},
    )
    runs = write_experiment(
        tmp_path / "runs", MULTI, system="DR_LOCAL_S3_BUCKET=runs\n", workers={2: "DR_WORLD_NAME=Bowtie_track\n"}
    )
    return drfc, runs / "run.env"


def test_a_bare_run_env_has_its_companions_in_dr_dir_when_set(tmp_path):
    """bin/activate.sh:132-134 exports DR_DIR, its own folder; a run.env given by path is only DR_CONFIG (155-157):
    system.env is read from $DIR (70-71), worker-N.env from $DR_DIR (scripts/training/prepare-config.py:143-146) and
    the custom files from $DR_DIR/custom_files (bin/scripts_wrapper.sh:80-84, dr-upload-custom-files)."""
    drfc, run_env = bare_run_env(tmp_path)
    training = read_training(run_env, drfc_dir=drfc)
    experiment = training.experiment
    assert experiment.run_env == run_env and experiment.system_env == drfc / "system.env"
    assert experiment.env["DR_LOCAL_S3_BUCKET"].value == "drfc"
    assert [f.path for f in experiment.worker_files] == [drfc / "worker-2.env"]
    assert training.worker_params[1]["WORLD_NAME"] == "Oval_track"
    assert set(training.custom_file_sources.values()) <= set((drfc / "custom_files").iterdir())
    assert any(n.startswith(f"{run_env} given by path: worker-N.env and custom_files/ from {drfc}") and "$DR_DIR" in n
               for n in training.notes)  # fmt: skip


def test_a_bare_run_env_has_its_companions_beside_it_without_dr_dir(tmp_path):
    """The same rule with DR_DIR unset (racer run outside an activated DRfC shell): racer reads run.env's folder, and
    says so, since DRfC would read its own folder."""
    _drfc, run_env = bare_run_env(tmp_path)
    training = read_training(run_env)
    experiment = training.experiment
    assert experiment.system_env == run_env.parent / "system.env"
    assert training.worker_params[1]["WORLD_NAME"] == "Bowtie_track"
    assert any(n.startswith(f"{run_env} given by path") and "DR_DIR is not set" in n for n in training.notes)
    with pytest.raises(DrfcFileError, match=r"DR_DIR=.*missing: not a folder"):
        read_experiment(run_env, drfc_dir=tmp_path / "missing")


def test_dr_dir_comes_from_the_environment_through_racers_configuration(tmp_path):
    """DR_DIR as an activated DRfC shell exports it (bin/activate.sh:134), read where racer reads its environment;
    `racer train --drfc run.env` follows it and prints the warnings before the notes."""
    assert drfc_dir({"DR_DIR": "  "}) is None and drfc_dir({}) is None
    assert drfc_dir({"DR_DIR": str(tmp_path)}) == tmp_path
    drfc, run_env = bare_run_env(tmp_path)
    (drfc / "worker-2.env").write_text("DR_WORLD_NAME=Oval_track # the oval\n")
    probe, seen = train_probe()
    result = CliRunner().invoke(probe, ["--drfc", str(run_env)], env={"DR_DIR": str(drfc)})
    assert result.exit_code == 0, result.output
    assert [w["WORLD_NAME"] for w in seen["workers"]] == ["reinvent_base", "Oval_track"]
    lines = result.output.splitlines()
    warning = next(i for i, line in enumerate(lines) if line.startswith("racer train --drfc: warning: "))
    assert f"{drfc / 'worker-2.env'}:1: a comment after the value" in lines[warning]
    assert warning < next(i for i, line in enumerate(lines) if line.startswith("racer train --drfc: note: "))


def test_crlf_line_ends_are_line_ends_with_a_warning(tmp_path):
    """bin/activate.sh:101-105 keeps the carriage return in the last word of a line: DR_TRAIN_MULTI_CONFIG is
    `True\\r` there, which scripts/training/start.sh:158 and prepare-config.py:122 do not take as True.
    scripts/training/prepare-config.py:147-150 opens worker-N.env in text mode, where CRLF is a line end. racer
    reads all three files' CRLF as line ends, and warns for each file."""
    folder = write_experiment(tmp_path / "exp", "", workers={2: ""})
    (folder / "run.env").write_bytes(MULTI.replace("\n", "\r\n").encode())  # DR_TRAIN_MULTI_CONFIG=True\r: off in DRfC
    (folder / "system.env").write_bytes(b"# system\r\nDR_CAR_NAME=FastCar\r\n")
    (folder / "worker-2.env").write_bytes(b"DR_WORLD_NAME=Oval_track\r\n")
    training = read_training(folder)
    assert training.experiment.env["DR_CAR_NAME"].value == "FastCar" and training.experiment.multi_config
    assert [w["WORLD_NAME"] for w in training.worker_params] == ["reinvent_base", "Oval_track"]
    warnings = training.experiment.warnings
    assert [w.split(": ")[0] for w in warnings] == [f"{folder}/system.env:1", f"{folder}/run.env:1",
                                                    f"{folder}/worker-2.env:1"]  # fmt: skip
    assert "CRLF) on lines 1-2: DRfC's activate.sh keeps" in warnings[0]
    assert "CRLF) on lines 1-17" in warnings[1] and "CRLF) on line 1: DRfC's prepare-config.py reads" in warnings[2]


def test_blank_lines_and_comments_in_worker_env_warn_by_line(tmp_path):
    """scripts/training/prepare-config.py:148-151 builds a dict of `tuple(line.split('='))` for every line that does
    not start with `#`: a blank line or an indented comment is no pair and raises ValueError, and a comment after
    a value stays part of it (DR_WORLD_NAME is 'Oval_track # the oval' there). racer skips those lines and reads the
    value before the comment, with a warning naming each line."""
    path = tmp_path / "worker-2.env"
    path.write_text(
        "# worker 2\nDR_WORLD_NAME=Oval_track   # the oval\n\n  # DR_RACE_TYPE=HEAD_TO_BOT\n"
        "DR_TRAIN_REVERSE_DIRECTION=True # not =False\n   \n"
    )
    file = read_worker_env(path)
    assert [(a.name, a.value, a.line) for a in file.assignments] == [
        ("DR_WORLD_NAME", "Oval_track", 2),
        ("DR_TRAIN_REVERSE_DIRECTION", "True", 5),
    ]
    line_2, line_4, line_5, blank = file.warnings
    assert line_2.startswith(f"{path}:2: a comment after the value") and "'Oval_track   # the oval'" in line_2
    assert line_4.startswith(f"{path}:4: an indented comment")
    assert line_5.startswith(f"{path}:5: a comment after the value") and "stops on this line" in line_5
    assert blank.startswith(f"{path}:3: blank lines 3, 6: DRfC's prepare-config.py stops")
