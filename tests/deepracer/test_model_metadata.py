"""model_metadata.json: every real file parses to what it says; every rule rejects bad input naming file and field."""

from __future__ import annotations

import copy
import json

import numpy as np
import pytest

from racer.shared.deepracer.model_metadata import (
    CAMERA_SENSORS,
    LIDAR_SENSORS,
    NEURAL_NETWORKS,
    SENSOR_NAMES,
    ContinuousActionSpace,
    DiscreteAction,
    LidarConfig,
    ModelMetadataError,
    load_model_metadata,
    model_metadata_to_dict,
    parse_model_metadata,
)


def real_metadata_files(data_dir):
    files = sorted((data_dir / "config").glob("*model_metadata*.json"))
    assert len(files) >= 10, files
    return files


def test_every_real_model_metadata_parses_to_its_contents(deepracer_data):
    for path in real_metadata_files(deepracer_data):
        raw = json.loads(path.read_text())
        metadata = load_model_metadata(path)
        expected_type = raw.get("action_space_type", "discrete")
        assert metadata.action_space_type == expected_type, path.name
        if expected_type == "discrete":
            assert metadata.num_actions == len(raw["action_space"])
            assert [(a.steering_angle_deg, a.speed_mps) for a in metadata.discrete_actions] == [
                (float(a["steering_angle"]), float(a["speed"])) for a in raw["action_space"]
            ]
            assert metadata.continuous_action_space is None
        else:
            space = raw["action_space"]
            assert metadata.num_actions == 2
            assert metadata.discrete_actions == ()
            assert metadata.continuous_action_space == ContinuousActionSpace(
                steering_angle_low_deg=space["steering_angle"]["low"],
                steering_angle_high_deg=space["steering_angle"]["high"],
                speed_low_mps=space["speed"]["low"],
                speed_high_mps=space["speed"]["high"],
            )
        assert metadata.sensors == tuple(raw["sensor"]), path.name
        assert metadata.neural_network == raw.get("neural_network", NEURAL_NETWORKS[0])
        assert metadata.training_algorithm == raw.get("training_algorithm", "clipped_ppo")
        assert metadata.version == (float(raw["version"]) if "version" in raw else 2.0)
        assert metadata.camera_sensor in raw["sensor"]
        lidars = [s for s in raw["sensor"] if s in LIDAR_SENSORS]
        assert metadata.lidar_sensor == (lidars[0] if lidars else None)


def test_specific_real_files(deepracer_data):
    config = deepracer_data / "config"
    console = load_model_metadata(config / "console2022_model_metadata.json")
    assert console.version == 4.0 and console.num_actions == 14
    assert console.discrete_actions[3] == DiscreteAction(steering_angle_deg=-20.0, speed_mps=2.0)
    assert console.lidar_config == LidarConfig(8, 8, 2.0)
    stereo = load_model_metadata(config / "dpr401_model_metadata_stereo_lidar_deep_two_speed_5steering.json")
    assert stereo.camera_sensor == "STEREO_CAMERAS" and stereo.lidar_sensor == "LIDAR"
    assert stereo.neural_network == "DEEP_CONVOLUTIONAL_NETWORK"
    sac = load_model_metadata(config / "dots_model_metadata_sac.json")
    assert sac.training_algorithm == "sac" and sac.version == 5.0
    assert sac.continuous_action_space.speed_low_mps == 0.5


def test_sensor_tuples():
    assert SENSOR_NAMES == CAMERA_SENSORS + LIDAR_SENSORS
    assert CAMERA_SENSORS == ("FRONT_FACING_CAMERA", "STEREO_CAMERAS", "LEFT_CAMERA", "observation")
    assert LIDAR_SENSORS == ("LIDAR", "SECTOR_LIDAR", "DISCRETIZED_SECTOR_LIDAR")


def test_round_trip_through_dict_for_every_real_file(deepracer_data):
    for path in real_metadata_files(deepracer_data):
        metadata = load_model_metadata(path)
        as_dict = model_metadata_to_dict(metadata)
        assert parse_model_metadata(json.loads(json.dumps(as_dict))) == metadata, path.name


def test_to_dict_uses_deepracer_keys(deepracer_data):
    metadata = load_model_metadata(deepracer_data / "config" / "console2022_model_metadata.json")
    as_dict = model_metadata_to_dict(metadata)
    raw = json.loads((deepracer_data / "config" / "console2022_model_metadata.json").read_text())
    assert set(as_dict) == set(raw)
    assert as_dict["action_space"] == raw["action_space"]
    assert float(as_dict["version"]) == float(raw["version"])


DISCRETE = {
    "action_space": [
        {"steering_angle": -30, "speed": 1.0},
        {"steering_angle": 0, "speed": 2.0},
        {"steering_angle": 30, "speed": 1.0},
    ],
    "sensor": ["FRONT_FACING_CAMERA"],
    "neural_network": "DEEP_CONVOLUTIONAL_NETWORK_SHALLOW",
    "training_algorithm": "clipped_ppo",
    "action_space_type": "discrete",
    "version": "5",
}
CONTINUOUS = {
    "action_space": {"steering_angle": {"low": -20, "high": 30}, "speed": {"low": 1.0, "high": 3.0}},
    "sensor": ["FRONT_FACING_CAMERA", "LIDAR"],
    "neural_network": "DEEP_CONVOLUTIONAL_NETWORK_DEEP",
    "training_algorithm": "clipped_ppo",
    "action_space_type": "continuous",
    "version": "5",
}


def changed(base, path, value):
    """A deep copy of `base` with the nested key path set to value (or removed when value is DELETE)."""
    data = copy.deepcopy(base)
    target = data
    for key in path[:-1]:
        target = target[key]
    if value is DELETE:
        del target[path[-1]]
    else:
        target[path[-1]] = value
    return data


DELETE = object()

BAD_INPUTS = [
    # (base, key path, new value, field named in the message, words the message must contain)
    (DISCRETE, ("action_space",), DELETE, "action_space", "missing"),
    (DISCRETE, ("action_space", 1, "speed"), 7.0, "action_space[1].speed", "7.0 is above 4.0 m/s"),
    (DISCRETE, ("action_space", 1, "speed"), 0.05, "action_space[1].speed", "below 0.1"),
    (DISCRETE, ("action_space", 2, "steering_angle"), 31, "action_space[2].steering_angle", "above 30.0 deg"),
    (DISCRETE, ("action_space", 0, "steering_angle"), -45, "action_space[0].steering_angle", "below -30.0 deg"),
    (DISCRETE, ("action_space", 0, "speed"), "1.0", "action_space[0].speed", "not a number"),
    (DISCRETE, ("action_space", 0, "speed"), True, "action_space[0].speed", "not a number"),
    (DISCRETE, ("action_space", 0, "speed"), DELETE, "action_space[0]", "missing key 'speed'"),
    (DISCRETE, ("action_space", 0), "left", "action_space[0]", "expected a JSON object"),
    (DISCRETE, ("action_space", 1, "index"), 5, "action_space[1].index", "does not match"),
    (DISCRETE, ("action_space",), [{"steering_angle": 0, "speed": 1}], "action_space", "2 to 30"),
    (DISCRETE, ("action_space",), [{"steering_angle": 0, "speed": 1}] * 31, "action_space", "2 to 30"),
    (DISCRETE, ("action_space",), CONTINUOUS["action_space"], "action_space", "continuous"),
    (DISCRETE, ("action_space_type",), "box", "action_space_type", "allowed: discrete, continuous"),
    (DISCRETE, ("training_algorithm",), "dqn", "training_algorithm", "allowed: clipped_ppo, sac"),
    (DISCRETE, ("training_algorithm",), "sac", "training_algorithm", "requires action_space_type 'continuous'"),
    (DISCRETE, ("neural_network",), ["RESNET"], "neural_network", "allowed: DEEP_CONVOLUTIONAL_NETWORK_SHALLOW"),
    (DISCRETE, ("sensor",), ["LIDAR"], "sensor", "exactly one camera"),
    (DISCRETE, ("sensor",), [], "sensor", "exactly one camera"),
    (DISCRETE, ("sensor",), ["FRONT_FACING_CAMERA", "STEREO_CAMERAS"], "sensor", "exactly one camera"),
    (DISCRETE, ("sensor",), ["FRONT_FACING_CAMERA", "LIDAR", "SECTOR_LIDAR"], "sensor", "at most one lidar"),
    (DISCRETE, ("sensor",), ["FRONT_FACING_CAMERA", "RADAR"], "sensor[1]", "'RADAR' is not a sensor"),
    (DISCRETE, ("sensor",), ["FRONT_FACING_CAMERA", "FRONT_FACING_CAMERA"], "sensor[1]", "listed twice"),
    (DISCRETE, ("sensor",), "FRONT_FACING_CAMERA", "sensor", "expected a list"),
    (DISCRETE, ("sensor",), DELETE, "sensor", "missing; version 5.0"),
    (DISCRETE, ("version",), "five", "version", "not a number"),
    (DISCRETE, ("version",), 0.5, "version", "not a SimApp version"),
    (DISCRETE, ("lidar_config",), {"num_sectors": 3}, "lidar_config.num_sectors", "allowed: 1, 2, 4, 8, 16, 32, 64"),
    (DISCRETE, ("lidar_config",), {"num_values_per_sector": 0}, "lidar_config.num_values_per_sector", "below 1"),
    (DISCRETE, ("lidar_config",), {"clipping_dist": 20.0}, "lidar_config.clipping_dist", "above 12.0 m"),
    (DISCRETE, ("lidar_config",), {"clipping_dist": 0.1}, "lidar_config.clipping_dist", "below 0.15 m"),
    (DISCRETE, ("lidar_config",), [8, 8, 2.0], "lidar_config", "expected a JSON object"),
    (CONTINUOUS, ("action_space",), DISCRETE["action_space"], "action_space", "discrete"),
    (CONTINUOUS, ("action_space", "speed", "low"), 0.2, "action_space.speed.low", "below 0.5 m/s"),
    (CONTINUOUS, ("action_space", "speed", "high"), 5, "action_space.speed.high", "above 4.0 m/s"),
    (CONTINUOUS, ("action_space", "speed", "low"), 3.0, "action_space.speed", "low 3.0 must be below high 3.0"),
    (CONTINUOUS, ("action_space", "steering_angle", "low"), 30, "action_space.steering_angle", "must be below"),
    (CONTINUOUS, ("action_space", "steering_angle", "high"), 40, "action_space.steering_angle.high", "above 30.0"),
    (CONTINUOUS, ("action_space", "steering_angle", "low"), DELETE, "action_space.steering_angle", "'low'"),
    (CONTINUOUS, ("action_space", "speed"), DELETE, "action_space", "missing key 'speed'"),
]


@pytest.mark.parametrize(("base", "path", "value", "field", "words"), BAD_INPUTS)
def test_each_rule_rejects_bad_input_naming_file_and_field(base, path, value, field, words):
    parse_model_metadata(base, source="good.json")  # the unchanged base is valid
    with pytest.raises(ModelMetadataError) as caught:
        parse_model_metadata(changed(base, path, value), source="custom_files/model_metadata.json")
    message = str(caught.value)
    assert message.startswith(f"custom_files/model_metadata.json: {field}: "), message
    assert words in message, message


def test_example_message_from_the_spec():
    data = changed(DISCRETE, ("action_space",), [dict(DISCRETE["action_space"][0]) for _ in range(4)])
    data["action_space"][3]["speed"] = 7.0
    with pytest.raises(
        ModelMetadataError, match=r"^model_metadata\.json: action_space\[3\]\.speed: 7\.0 is above 4\.0 m/s$"
    ):
        parse_model_metadata(data)


def test_top_level_must_be_an_object():
    with pytest.raises(ModelMetadataError, match="^x.json: expected a JSON object"):
        parse_model_metadata([1, 2], source="x.json")


def test_defaults_for_missing_keys():
    minimal = {"action_space": DISCRETE["action_space"]}
    metadata = parse_model_metadata(minimal)
    assert metadata.sensors == ("observation",)
    assert metadata.version == 1.0
    assert metadata.action_space_type == "discrete"
    assert metadata.training_algorithm == "clipped_ppo"
    assert metadata.neural_network == "DEEP_CONVOLUTIONAL_NETWORK_SHALLOW"
    assert metadata.lidar_config == LidarConfig(num_sectors=8, num_values_per_sector=8, clipping_dist_m=2.0)
    with_sensor = parse_model_metadata({**minimal, "sensor": ["LEFT_CAMERA"]})
    assert with_sensor.version == 2.0 and with_sensor.camera_sensor == "LEFT_CAMERA"
    assert with_sensor.lidar_sensor is None


def test_type_and_algorithm_are_normalised_and_extra_keys_ignored():
    data = {**CONTINUOUS, "action_space_type": " Continuous ", "training_algorithm": "SAC", "preprocess_type": "RGB"}
    metadata = parse_model_metadata(data)
    assert metadata.action_space_type == "continuous" and metadata.training_algorithm == "sac"


def test_partial_lidar_config_keeps_defaults_for_the_rest():
    metadata = parse_model_metadata({**DISCRETE, "lidar_config": {"num_sectors": 16, "clipping_dist": 1}})
    assert metadata.lidar_config == LidarConfig(num_sectors=16, num_values_per_sector=8, clipping_dist_m=1.0)


def test_scale_continuous_action():
    metadata = parse_model_metadata(CONTINUOUS)  # steering [-20, 30], speed [1, 3]
    assert metadata.scale_continuous_action([-1.0, -1.0]) == (-20.0, 1.0)
    assert metadata.scale_continuous_action([1.0, 1.0]) == (30.0, 3.0)
    assert metadata.scale_continuous_action([0.0, 0.0]) == (5.0, 2.0)
    assert metadata.scale_continuous_action((0.5, -0.5)) == pytest.approx((17.5, 1.5))
    assert metadata.scale_continuous_action([7.0, -3.0]) == (30.0, 1.0)  # clipped first
    with pytest.raises(ValueError, match="2 values"):
        metadata.scale_continuous_action([0.0])
    with pytest.raises(ValueError, match="NaN"):
        metadata.scale_continuous_action([float("nan"), 0.0])
    with pytest.raises(ValueError, match="discrete"):
        parse_model_metadata(DISCRETE).scale_continuous_action([0.0, 0.0])


def test_scale_accepts_numpy_arrays():
    metadata = parse_model_metadata(CONTINUOUS)
    steering, speed = metadata.scale_continuous_action(np.array([0.0, 1.0], dtype=np.float32))
    assert (steering, speed) == (5.0, 3.0)
    assert type(steering) is float


def test_load_reports_malformed_json_with_line_and_column(tmp_path):
    path = tmp_path / "model_metadata.json"
    path.write_text('{\n  "action_space": [\n    {"steering_angle": 0, "speed": 1.0,}\n  ]\n}\n')
    with pytest.raises(ModelMetadataError) as caught:
        load_model_metadata(path)
    message = str(caught.value)
    assert message.startswith(f"{path}: invalid JSON at line 3, column"), message


def test_load_names_the_file_for_rule_errors(tmp_path):
    path = tmp_path / "mm.json"
    path.write_text(json.dumps(changed(DISCRETE, ("neural_network",), "VGG")))
    with pytest.raises(ModelMetadataError, match=f"^{path}: neural_network: "):
        load_model_metadata(path)


def test_load_accepts_a_utf8_bom(tmp_path):
    path = tmp_path / "bom.json"
    path.write_bytes(b"\xef\xbb\xbf" + json.dumps(DISCRETE).encode())
    assert load_model_metadata(path).num_actions == 3


def test_a_custom_network_name_needs_the_network_file_beside_it(tmp_path):
    """A neural_network that is not DeepRacer's is the name of network.json in the same folder; the error names
    both files."""
    path = tmp_path / "model_metadata.json"
    path.write_text(json.dumps(changed(DISCRETE, ("neural_network",), "WIDE")))
    assert parse_model_metadata(json.loads(path.read_text()), "dict").neural_network == "WIDE"  # stores carry it
    with pytest.raises(ModelMetadataError, match=f"^{path}: neural_network: 'WIDE' .*network.json.*there is none"):
        load_model_metadata(path)
    (tmp_path / "network.json").write_text(json.dumps({"name": "NARROW"}))
    with pytest.raises(ModelMetadataError, match="its name is 'NARROW'"):
        load_model_metadata(path)
    (tmp_path / "network.json").write_text(json.dumps({"name": "WIDE"}))
    assert load_model_metadata(path).neural_network == "WIDE"
