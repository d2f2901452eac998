"""A DRfC experiment's files found and applied as DRfC does: system.env then run.env, DR_EXPERIMENT_NAME, and
worker-N.env one after another (deepracer-for-cloud 2eb1a1f1 bin/activate.sh, scripts/training/prepare-config.py)."""

from __future__ import annotations

import pytest

from racer.drfc.experiment import read_experiment
from racer.drfc.shell_env import DrfcFileError
from racer.drfc.training import read_training
from racer.drfc.training_params import experiment_worker_params
from tests.drfc.conftest import write_experiment

RUN = (
    "DR_WORLD_NAME=reinvent_base\n"
    "DR_RACE_TYPE=TIME_TRIAL\n"
    "DR_TRAIN_MULTI_CONFIG=True\n"
    "DR_TRAIN_MIN_EVAL_TRIALS=3\n"
    "DR_TRAIN_BEST_MODEL_METRIC=reward\n"
    "DR_TRAIN_REVERSE_DIRECTION=False\n"
    "DR_TRAIN_CHANGE_START_POSITION=True\n"
    "DR_TRAIN_ALTERNATE_DRIVING_DIRECTION=False\n"
    "DR_TRAIN_ROUND_ROBIN_ADVANCE_DIST=0.05\n"
    "DR_TRAIN_START_POSITION_OFFSET=0.0\n"
    "DR_ENABLE_DOMAIN_RANDOMIZATION=False\n"
    "DR_OA_NUMBER_OF_OBSTACLES=6\n"
    "DR_OA_MIN_DISTANCE_BETWEEN_OBSTACLES=2.0\n"
    "DR_OA_RANDOMIZE_OBSTACLE_LOCATIONS=False\n"
    "DR_OA_IS_OBSTACLE_BOT_CAR=False\n"
    "DR_LOCAL_S3_MODEL_PREFIX=my-model\n"
)


def test_later_workers_inherit_what_earlier_worker_files_set(tmp_path):
    folder = write_experiment(
        tmp_path / "exp",
        RUN,
        system="DR_WORKERS=4\n",
        workers={
            2: "DR_WORLD_NAME=reInvent2019_track\nDR_RACE_TYPE=OBJECT_AVOIDANCE\nDR_OA_NUMBER_OF_OBSTACLES=3\n"
            "DR_TRAIN_MIN_EVAL_TRIALS=1\n",
            3: "DR_TRAIN_REVERSE_DIRECTION=True\n",
            4: "DR_RACE_TYPE=TIME_TRIAL\nDR_TRAIN_ROUND_ROBIN_ADVANCE_DIST=0.1\n",
        },
    )
    training = read_training(folder)
    tracks = [w["WORLD_NAME"] for w in training.worker_params]
    assert tracks == ["reinvent_base", "reInvent2019_track", "reInvent2019_track", "reInvent2019_track"]
    races = [w["RACE_TYPE"] for w in training.worker_params]
    assert races == ["TIME_TRIAL", "OBJECT_AVOIDANCE", "OBJECT_AVOIDANCE", "TIME_TRIAL"]
    assert [w.get("NUMBER_OF_OBSTACLES") for w in training.worker_params] == [None, "3", "3", None]
    # worker-3.env's setting stays in prepare-config.py's environment: worker 4 drives reversed too
    assert [w["REVERSE_DIR"] for w in training.worker_params] == ["False", "False", "True", "True"]
    assert [w["ROUND_ROBIN_ADVANCE_DIST"] for w in training.worker_params] == ["0.05", "0.05", "0.05", "0.1"]
    # not a per-worker variable: worker 1's value for every worker, and said once
    assert {w["MIN_EVAL_TRIALS"] for w in training.worker_params} == {"3"}
    assert {w["BEST_MODEL_METRIC"] for w in training.worker_params} == {"reward"}
    said = [n for n in training.notes if "DR_TRAIN_MIN_EVAL_TRIALS" in n]
    assert len(said) == 1 and "worker-2.env:4" in said[0]
    assert training.model_prefix == "my-model"


def test_a_worker_variable_with_no_default_for_later_workers_is_refused_by_name(tmp_path):
    """prepare-config.py reads the obstacle keys of workers 2+ without defaults: unset, DRfC writes null."""
    run = "\n".join(line for line in RUN.splitlines() if not line.startswith("DR_OA_NUMBER")) + "\n"
    folder = write_experiment(
        tmp_path / "exp", run, system="DR_WORKERS=2\n", workers={2: "DR_RACE_TYPE=OBJECT_AVOIDANCE\n"}
    )
    with pytest.raises(DrfcFileError, match=r"worker 1 \(DRfC's worker 2\): DR_OA_NUMBER_OF_OBSTACLES is not set"):
        read_training(folder)


def test_worker_one_gets_prepare_configs_defaults(tmp_path):
    folder = write_experiment(
        tmp_path / "exp", 'DR_RACE_TYPE=OBJECT_AVOIDANCE\nDR_OA_OBJECT_POSITIONS="0.2,1;0.6,-1"\n'
    )
    (params,) = experiment_worker_params(read_experiment(folder))
    assert params["WORLD_NAME"].value == "LGSWide" and params["WORLD_NAME"].origin is None
    assert params["RANDOMIZE_OBSTACLE_LOCATIONS"].value == "True"  # prepare-config.py's default, not the template's
    assert params["OBJECT_POSITIONS"].value == "0.2,1;0.6,-1"
    assert params["NUMBER_OF_OBSTACLES"].value == "2"  # the positions set the count
    assert params["CHANGE_START_POSITION"].value == "true"


def test_the_older_variable_names_serve_worker_one(tmp_path):
    folder = write_experiment(tmp_path / "exp", "DR_ALTERNATE_DRIVING_DIRECTION=True\nDR_CHANGE_START_POSITION=False\n")
    (params,) = read_training(folder).worker_params
    assert params["ALTERNATE_DRIVING_DIRECTION"] == "True" and params["CHANGE_START_POSITION"] == "False"


def test_multi_config_needs_the_exact_text_true(tmp_path):
    folder = write_experiment(
        tmp_path / "exp",
        RUN.replace("DR_TRAIN_MULTI_CONFIG=True", "DR_TRAIN_MULTI_CONFIG=true"),
        system="DR_WORKERS=2\n",
        workers={2: "DR_WORLD_NAME=Oval_track\n"},
    )
    experiment = read_experiment(folder)
    assert not experiment.multi_config and experiment.num_workers == 2
    assert [w["WORLD_NAME"].value for w in experiment_worker_params(experiment)] == ["reinvent_base"] * 2
    assert any("exact text 'True'" in note for note in experiment.notes)
    assert any("not read" in note and "worker-2.env" in note for note in experiment.notes)


def test_worker_files_beyond_dr_workers_are_not_read_and_a_missing_one_stops(tmp_path):
    folder = write_experiment(
        tmp_path / "exp", RUN, system="DR_WORKERS=2\n", workers={2: "DR_WORLD_NAME=Oval_track\n", 3: "bad line\n"}
    )
    experiment = read_experiment(folder)
    assert experiment.num_workers == 2
    assert any("worker-3.env" in note for note in experiment.notes)
    with pytest.raises(DrfcFileError, match=r"worker-3\.env:1: 'bad line'"):
        read_experiment(folder, num_workers=3)  # --workers 3 stands for DR_WORKERS: worker-3.env is read now
    (folder / "worker-3.env").write_text("DR_WORLD_NAME=Bowtie_track\n")
    with pytest.raises(DrfcFileError, match=r"worker-4\.env: missing"):
        read_experiment(folder, num_workers=4)


def test_system_env_is_read_first_and_run_env_refers_to_it(tmp_path):
    folder = write_experiment(
        tmp_path / "exp",
        "DR_LOCAL_S3_MODEL_PREFIX=$DR_LOCAL_S3_BUCKET-model\nDR_WORKERS=2\n",
        system="DR_LOCAL_S3_BUCKET=shared\nDR_WORKERS=5\n",
    )
    training = read_training(folder)
    assert training.model_prefix == "shared-model" and training.num_workers == 2


def test_dr_experiment_name_picks_the_experiment_folder(tmp_path):
    root = write_experiment(tmp_path / "drfc", "DR_WORLD_NAME=reinvent_base\n", system="DR_EXPERIMENT_NAME=fast\n")
    write_experiment(root / "experiments" / "fast", "DR_WORLD_NAME=Oval_track\n")
    write_experiment(root / "experiments" / "slow", "DR_WORLD_NAME=Bowtie_track\n")
    assert read_training(root).worker_params[0]["WORLD_NAME"] == "Oval_track"
    # the experiment folder given is `activate.sh -e slow`: it wins over system.env's name, with system.env read
    slow = read_experiment(root / "experiments" / "slow")
    assert slow.system_env == root / "system.env"
    assert read_training(root / "experiments" / "slow").worker_params[0]["WORLD_NAME"] == "Bowtie_track"
    with pytest.raises(DrfcFileError, match="DRfC would read"):
        read_experiment(root / "run.env")
    (root / "system.env").write_text("DR_EXPERIMENT_NAME=missing\n")
    with pytest.raises(DrfcFileError, match=r"system\.env:1: DR_EXPERIMENT_NAME=missing"):
        read_experiment(root)


@pytest.mark.parametrize(
    ("line", "message"),
    [
        (
            "DR_TRAIN_REVERSE_DIRECTION=yes",
            r"run\.env:2: DR_TRAIN_REVERSE_DIRECTION=yes: the SimApp reads True or False",
        ),
        (
            "DR_TRAIN_ROUND_ROBIN_ADVANCE_DIST=often",
            r"run\.env:2: DR_TRAIN_ROUND_ROBIN_ADVANCE_DIST=often: not a number",
        ),
        ("DR_TRAIN_ROUND_ROBIN_ADVANCE_DIST=1.5", r"ROUND_ROBIN_ADVANCE_DIST 1\.5 is outside .*run\.env:2"),
        ("DR_RACE_TYPE=DRAG_RACE", r"RACE_TYPE: 'DRAG_RACE' is not one of .*run\.env:2: DR_RACE_TYPE=DRAG_RACE"),
        ("DR_TRAIN_BEST_MODEL_METRIC=speed", r"BEST_MODEL_METRIC 'speed'.*run\.env:2"),
        ("DR_WORKERS=two", r"run\.env:2: DR_WORKERS='two' is not a number of workers"),
    ],
)
def test_a_bad_value_names_its_variable_and_line(tmp_path, line, message):
    folder = write_experiment(tmp_path / "exp", f"DR_WORLD_NAME=reinvent_base\n{line}\n")
    with pytest.raises(DrfcFileError, match=message):
        read_training(folder)


def test_custom_files_come_from_the_keys_below_the_custom_files_prefix(tmp_path):
    folder = write_experiment(
        tmp_path / "exp",
        "DR_LOCAL_S3_CUSTOM_FILES_PREFIX=custom_files\n"
        "DR_LOCAL_S3_REWARD_KEY=$DR_LOCAL_S3_CUSTOM_FILES_PREFIX/v2/reward.py\n",
    )
    (folder / "custom_files" / "v2").mkdir()
    (folder / "custom_files" / "v2" / "reward.py").write_text("def reward_function(params):\n    return 2.0\n")
    sources = read_training(folder).custom_file_sources
    assert sources["reward_function.py"] == folder / "custom_files" / "v2" / "reward.py"
    assert sources["model_metadata.json"] == folder / "custom_files" / "model_metadata.json"
    (folder / "run.env").write_text("DR_LOCAL_S3_REWARD_KEY=elsewhere/reward_function.py\n")
    with pytest.raises(DrfcFileError, match=r"run\.env:1: DR_LOCAL_S3_REWARD_KEY=elsewhere/reward_function\.py: not a"):
        read_training(folder)


def test_the_clone_follows_the_simapps_reading(tmp_path):
    run = "DR_LOCAL_S3_PRETRAINED={}\nDR_LOCAL_S3_PRETRAINED_PREFIX=base-model\nDR_LOCAL_S3_PRETRAINED_CHECKPOINT={}\n"
    for pretrained, checkpoint, expected in (
        ("True", "BEST", ("base-model", "best")),
        ("t", "last", ("base-model", "last")),
        ("False", "best", (None, "last")),
    ):
        folder = write_experiment(tmp_path / f"exp-{pretrained}", run.format(pretrained, checkpoint))
        training = read_training(folder)
        assert (training.pretrained_prefix, training.pretrained_checkpoint) == expected
