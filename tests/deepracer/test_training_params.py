"""training_params.yaml: real DeepRacer yaml files parse, typed accessors convert strings, errors name file and key."""

from __future__ import annotations

import pytest
import yaml

from racer.shared.deepracer.training_params import (
    TrainingParams,
    TrainingParamsError,
    load_training_params,
    parse_training_params,
    training_params_to_yaml,
)


def real_yaml_files(data_dir):
    files = sorted((data_dir / "config").glob("*.yaml"))
    assert len(files) >= 3, files
    return files


def test_every_real_yaml_parses_with_all_keys_as_strings(deepracer_data):
    for path in real_yaml_files(deepracer_data):
        raw = yaml.safe_load(path.read_text())
        params = load_training_params(path)
        assert list(params.values) == list(raw), path.name
        for key, value in raw.items():
            assert params[key] == value and isinstance(params[key], str), (path.name, key)


def test_simapp_sample_typed_values(deepracer_data):
    params = load_training_params(deepracer_data / "config" / "simapp_sample-training_params.yaml")
    assert params.world_name == "Vegas_track"
    assert params.race_type == "TIME_TRIAL" and params.job_type == "TRAINING"
    assert params.change_start_position is True
    assert params.alternate_driving_direction is False
    assert params.get_int("NUMBER_OF_EPISODES") == 0
    assert params.get_str("TARGET_REWARD_SCORE") == "None"
    # keys absent from the file fall back to the SimApp defaults
    assert params.round_robin_advance_dist == 0.05
    assert params.start_position_offset == 0.0
    assert params.min_eval_trials == 5 and params.best_model_metric == "progress"
    assert params.number_of_resets == 0 and params.num_workers == 1


def test_workshop_templates(deepracer_data):
    training = load_training_params(deepracer_data / "config" / "dpr401_training_yaml_template.yaml")
    assert training.number_of_bot_cars == 0 and training.get_float("BOT_CAR_SPEED") == 0.2
    assert training.get_bool("RANDOMIZE_BOT_CAR_LOCATIONS") is True
    assert training.enable_domain_randomization is False
    evaluation = load_training_params(deepracer_data / "config" / "dpr401_evaluation_yaml_template.yaml")
    assert evaluation.number_of_trials == 5 and evaluation.number_of_resets == 10000
    assert evaluation.is_continuous is False
    assert evaluation.off_track_penalty_s == 0.0 and evaluation.get_float("PENALTY_SECONDS") == 2.0
    with pytest.raises(TrainingParamsError, match="WORLD_NAME: empty"):
        evaluation.world_name  # noqa: B018 - the template leaves it blank


def test_console_style_per_car_lists_and_plain_yaml_types():
    params = parse_training_params(
        "CAR_COLOR: ['Black']\nMODEL_S3_BUCKET: [a, b]\nNUMBER_OF_TRIALS: 3\nIS_CONTINUOUS: False\n"
        "ROUND_ROBIN_ADVANCE_DIST: 0.1\nWORLD_NAME: reinvent_base\nEMPTY:\n",
        source="eval_params.yaml",
    )
    assert params["CAR_COLOR"] == ("Black",)
    assert params.get_str("CAR_COLOR") == "Black"
    assert params.get_str("MODEL_S3_BUCKET", racecar_index=1) == "b"
    assert params.get_list("MODEL_S3_BUCKET") == ("a", "b") and params.get_list("WORLD_NAME") == ("reinvent_base",)
    assert params.number_of_trials == 3 and params["NUMBER_OF_TRIALS"] == "3"
    assert params.is_continuous is False and params["IS_CONTINUOUS"] == "False"
    assert params.round_robin_advance_dist == 0.1
    assert params["EMPTY"] == ""
    with pytest.raises(TrainingParamsError, match="^eval_params.yaml: MODEL_S3_BUCKET: has 2 per-car values"):
        params.get_str("MODEL_S3_BUCKET", racecar_index=2)


@pytest.mark.parametrize("text", ["True", "true", "TRUE", " true "])
def test_true_spellings(text):
    assert parse_training_params(f'CHANGE_START_POSITION: "{text}"').change_start_position is True


@pytest.mark.parametrize("text", ["False", "false", "FALSE"])
def test_false_spellings(text):
    assert parse_training_params(f'REVERSE_DIR: "{text}"').reverse_dir is False


BAD_VALUES = [
    (
        'CHANGE_START_POSITION: "yes please"',
        "change_start_position",
        "CHANGE_START_POSITION: 'yes please' is not true or false",
    ),
    (
        'ROUND_ROBIN_ADVANCE_DIST: "fast"',
        "round_robin_advance_dist",
        "ROUND_ROBIN_ADVANCE_DIST: 'fast' is not a number",
    ),
    ('ROUND_ROBIN_ADVANCE_DIST: "nan"', "round_robin_advance_dist", "ROUND_ROBIN_ADVANCE_DIST: 'nan' is not a finite"),
    ('NUMBER_OF_RESETS: "2.5"', "number_of_resets", "NUMBER_OF_RESETS: '2.5' is not a whole number"),
    ('MIN_EVAL_TRIALS: ""', "min_eval_trials", "MIN_EVAL_TRIALS: '' is not a number"),
    ("RACE_TYPE: x", "world_name", "WORLD_NAME: missing"),
]


@pytest.mark.parametrize(("text", "accessor", "words"), BAD_VALUES)
def test_bad_values_name_file_and_key(text, accessor, words):
    params = parse_training_params(text, source="custom/training_params.yaml")
    with pytest.raises(TrainingParamsError) as caught:
        getattr(params, accessor)
    assert str(caught.value).startswith(f"custom/training_params.yaml: {words}"), str(caught.value)


def test_ints_written_as_floats_are_accepted():
    assert parse_training_params('NUMBER_OF_TRIALS: "3.0"').number_of_trials == 3


BAD_FILES = [
    ("WORLD_NAME: [unclosed\n", "invalid YAML at line 2"),
    ("- a\n- b\n", "expected a mapping"),
    ("OBJECT: {a: 1}\n", "OBJECT: {'a': 1} is not a scalar"),
    ("POSITIONS: [[1, 2]]\n", "POSITIONS[0]: [1, 2] is not a scalar"),
    ("1: x\n", "key 1 is not a string"),
]


@pytest.mark.parametrize(("text", "words"), BAD_FILES)
def test_bad_files_name_the_file(text, words, tmp_path):
    path = tmp_path / "training_params.yaml"
    path.write_text(text)
    with pytest.raises(TrainingParamsError) as caught:
        load_training_params(path)
    assert str(caught.value).startswith(f"{path}: "), str(caught.value)
    assert words in str(caught.value), str(caught.value)


def test_write_then_read_round_trip(deepracer_data):
    for path in real_yaml_files(deepracer_data):
        params = load_training_params(path)
        text = training_params_to_yaml(params)
        assert text.startswith("---\n")
        again = parse_training_params(text)
        assert dict(again.values) == dict(params.values), path.name
        # every value is written as a string, as DRfC does
        assert all(isinstance(value, str) for value in yaml.safe_load(text).values())


def test_write_from_python_values():
    text = training_params_to_yaml(
        {"WORLD_NAME": "reinvent_base", "CHANGE_START_POSITION": True, "ROUND_ROBIN_ADVANCE_DIST": 0.05,
         "NUMBER_OF_RESETS": 0, "CAR_COLOR": ["Blue", "Red"]}
    )  # fmt: skip
    assert yaml.safe_load(text) == {
        "WORLD_NAME": "reinvent_base",
        "CHANGE_START_POSITION": "True",
        "ROUND_ROBIN_ADVANCE_DIST": "0.05",
        "NUMBER_OF_RESETS": "0",
        "CAR_COLOR": ["Blue", "Red"],
    }
    params = parse_training_params(text)
    assert params.change_start_position is True and params.get_str("CAR_COLOR", racecar_index=1) == "Red"
    assert list(params.values)[0] == "WORLD_NAME"


def test_empty_file_has_only_defaults():
    params = parse_training_params("")
    assert params.values == {} and params.change_start_position is True
    assert TrainingParams().reverse_dir is False
