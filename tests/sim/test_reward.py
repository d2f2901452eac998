"""Reward params (every key, DeepRacer types) and loading/calling users' reward functions."""

from __future__ import annotations

import csv
import math

import pytest

from racer.shared.sim.reward.function import RewardFunctionError, default_evaluation_reward, load_reward_function
from racer.shared.sim.reward.params import PARAM_KEYS, RewardObject, make_reward_params
from racer.shared.sim.tracks.track import Track

TEMPLATE_RETURNING_ELLIPSIS = "awsdoc_input_example_1.py"


@pytest.fixture(scope="module")
def track(deepracer_data):
    return Track.load(deepracer_data / "routes" / "reinvent_base.npy")


def _real_params(track, deepracer_data, limit=60, objects=()):
    """Params rebuilt from real simtrace rows (console 2022, reinvent_base)."""
    path = deepracer_data / "simtrace" / "console2022_training_0-iteration.csv"
    with path.open(newline="") as handle:
        rows = list(csv.DictReader(handle))[:limit]
    return [
        make_reward_params(
            track,
            x=float(r["X"]),
            y=float(r["Y"]),
            heading_deg=float(r["yaw"]),
            speed_mps=float(r["throttle"]),
            steering_angle_deg=float(r["steer"]),
            steps=float(r["steps"]),
            progress=float(r["progress"]),
            all_wheels_on_track=r["all_wheels_on_track"] == "True",
            is_offtrack=r["episode_status"] == "off_track",
            sim_time_s=float(r["tstamp"]),
            objects=objects,
        )
        for r in rows
    ]


def test_params_have_every_key_with_deepracer_types(track, deepracer_data):
    params = _real_params(track, deepracer_data, limit=1)[0]
    assert tuple(params) == PARAM_KEYS
    assert isinstance(params["steps"], float) and params["steps"] == 1.0
    assert isinstance(params["waypoints"], list) and isinstance(params["waypoints"][0], tuple)
    assert len(params["waypoints"]) == track.num_waypoints and params["waypoints"][0] == params["waypoints"][-1]
    assert params["closest_waypoints"] == [0, 1] and all(type(i) is int for i in params["closest_waypoints"])
    for key in (
        "all_wheels_on_track",
        "is_left_of_center",
        "is_reversed",
        "is_crashed",
        "is_offtrack",
        "object_in_camera",
    ):
        assert type(params[key]) is bool, key
    for key in (
        "x",
        "y",
        "heading",
        "distance_from_center",
        "projection_distance",
        "speed",
        "steering_angle",
        "track_width",
        "track_length",
        "sim_time",
    ):
        assert type(params[key]) is float, key
    assert params["closest_objects"] == [0, 0] and params["objects_location"] == []
    assert params["track_length"] == pytest.approx(17.709159380834848, abs=1e-12)
    assert params["track_width"] == pytest.approx(0.762, abs=0.01)
    assert params["projection_distance"] == pytest.approx(0.14, abs=0.01)
    assert params["is_reversed"] is False
    assert (
        track.reversed().direction_reversed
        and make_reward_params(
            track.reversed(),
            x=3.2,
            y=0.68,
            heading_deg=180.0,
            speed_mps=1.0,
            steering_angle_deg=0.0,
            steps=1.0,
            progress=0.0,
            all_wheels_on_track=True,
            is_offtrack=False,
        )["is_reversed"]
        is True
    )


def test_object_params(track):
    ahead = RewardObject(x=track.center_line[10, 0], y=track.center_line[10, 1])
    behind = RewardObject(
        x=track.inner_border[60, 0] * 0.8 + track.center_line[60, 0] * 0.2,
        y=track.inner_border[60, 1] * 0.8 + track.center_line[60, 1] * 0.2,
    )
    x, y = track.center_line[3]
    params = make_reward_params(
        track,
        x=x,
        y=y,
        heading_deg=0.0,
        speed_mps=1.0,
        steering_angle_deg=0.0,
        steps=2.0,
        progress=1.0,
        all_wheels_on_track=True,
        is_offtrack=False,
        objects=[behind, ahead],
    )
    assert params["closest_objects"] == [0, 1]
    assert params["objects_distance"][1] < params["objects_distance"][0]
    assert params["objects_distance_from_center"][1] == pytest.approx(0.0, abs=1e-12)
    assert params["objects_left_of_center"][0] is True  # inner border side of a ccw track is the left
    assert params["objects_speed"] == [0.0, 0.0]


def test_every_real_reward_function_runs_unmodified(track, deepracer_data):
    files = sorted((deepracer_data / "reward_functions").glob("*.py"))
    assert len(files) >= 15
    plain = _real_params(track, deepracer_data)
    x, y = track.center_line[12]
    with_objects = _real_params(track, deepracer_data, objects=[RewardObject(x=x, y=y)])
    ran = 0
    for path in files:
        function = load_reward_function(path)
        if path.name == TEMPLATE_RETURNING_ELLIPSIS:
            with pytest.raises(RewardFunctionError, match=TEMPLATE_RETURNING_ELLIPSIS):
                function(plain[0])
            continue
        params_list = with_objects if "object_avoidance" in path.name else plain
        for params in params_list:
            reward = function(params)
            assert isinstance(reward, float) and math.isfinite(reward), path.name
        ran += 1
    assert ran == len(files) - 1


def test_module_state_persists_between_calls(track, deepracer_data):
    function = load_reward_function(deepracer_data / "reward_functions" / "analysis_reward_sample.py")
    params = _real_params(track, deepracer_data, limit=3)
    function(params[0])
    first_time = function.module.reward_object.initial_time
    function(params[1])
    assert function.module.reward_object.previous_steps == params[1]["steps"]
    assert function.module.reward_object.initial_time == first_time


def test_reward_function_cannot_corrupt_the_callers_params(track, tmp_path):
    path = tmp_path / "mutating.py"
    path.write_text(
        "def reward_function(params):\n    params['waypoints'].clear()\n    params['closest_waypoints'][0] = 99\n    return 1.0\n"
    )
    params = make_reward_params(
        track,
        x=3.3,
        y=0.7,
        heading_deg=0.0,
        speed_mps=1.0,
        steering_angle_deg=0.0,
        steps=1.0,
        progress=0.0,
        all_wheels_on_track=True,
        is_offtrack=False,
    )
    load_reward_function(path)(params)
    assert len(params["waypoints"]) == track.num_waypoints and params["closest_waypoints"][0] != 99


@pytest.mark.parametrize(
    ("body", "message"),
    [
        ("    return float('nan')\n", "finite"),
        ("    return float('inf')\n", "finite"),
        ("    return 'fast'\n", "must return a number"),
        ("    return 'nan'\n", "finite"),
        ("    return ...\n", "must return a number"),
        ("    return None\n", "must return a number"),
        ("    return 100001.0\n", r"within \[-100000, 100000\]"),
        ("    return -2e5\n", "within"),
    ],
)
def test_bad_results_give_clear_errors(tmp_path, track, body, message):
    path = tmp_path / "bad_reward.py"
    path.write_text("def reward_function(params):\n" + body)
    params = make_reward_params(
        track,
        x=3.3,
        y=0.7,
        heading_deg=0.0,
        speed_mps=1.0,
        steering_angle_deg=0.0,
        steps=1.0,
        progress=0.0,
        all_wheels_on_track=True,
        is_offtrack=False,
    )
    with pytest.raises(RewardFunctionError, match=message) as info:
        load_reward_function(path)(params)
    assert str(path) in str(info.value)


def test_a_numeric_string_is_a_reward_as_the_simapps_float_makes_it_one(tmp_path, track):
    """rollout_agent_ctrl.py: `reward = float(self._reward_(params))`, so '1.5' and ' 2e-3 ' are rewards."""
    path = tmp_path / "string_reward.py"
    path.write_text("def reward_function(params):\n    return '1.5' if params['all_wheels_on_track'] else ' 2e-3 '\n")
    function = load_reward_function(path)
    for on_track, expected in ((True, 1.5), (False, 0.002)):
        params = make_reward_params(
            track,
            x=3.3,
            y=0.7,
            heading_deg=0.0,
            speed_mps=1.0,
            steering_angle_deg=0.0,
            steps=1.0,
            progress=0.0,
            all_wheels_on_track=on_track,
            is_offtrack=False,
        )
        assert function(params) == expected


def test_raising_function_shows_file_and_line(tmp_path):
    path = tmp_path / "raising.py"
    path.write_text(
        "import math\n\ndef reward_function(params):\n    width = params['track_width']\n    return math.sqrt(-width)\n"
    )
    with pytest.raises(RewardFunctionError) as info:
        load_reward_function(path)({"track_width": 1.0})
    text = str(info.value)
    assert str(path) in text and "line 5" in text and "math.sqrt(-width)" in text and "ValueError" in text


def test_load_errors_name_the_file(tmp_path):
    missing = tmp_path / "missing.py"
    with pytest.raises(RewardFunctionError, match="missing.py"):
        load_reward_function(missing)
    syntax = tmp_path / "syntax.py"
    syntax.write_text("def reward_function(params)\n    return 1.0\n")
    with pytest.raises(RewardFunctionError, match=r"syntax.py:1: syntax error"):
        load_reward_function(syntax)
    nameless = tmp_path / "nameless.py"
    nameless.write_text("def reward(params):\n    return 1.0\n")
    with pytest.raises(RewardFunctionError, match="nameless.py: defines no function named 'reward_function'"):
        load_reward_function(nameless)


def test_default_evaluation_reward_markers():
    assert default_evaluation_reward({"track_width": 1.0, "distance_from_center": 0.05}) == 1.0
    assert default_evaluation_reward({"track_width": 1.0, "distance_from_center": 0.2}) == 0.5
    assert default_evaluation_reward({"track_width": 1.0, "distance_from_center": 0.4}) == 0.1
    assert default_evaluation_reward({"track_width": 1.0, "distance_from_center": 0.6}) == 1e-3


def test_default_evaluation_reward_reproduces_real_evaluation_simtraces(track, deepracer_data):
    """Evaluation rewards depend only on X, Y: rebuilding params from each row must give the logged reward."""
    for name in ("console2022_evaluation_0-iteration.csv", "drfc1_evaluation_0-iteration.csv"):
        with (deepracer_data / "simtrace" / name).open(newline="") as handle:
            rows = [r for r in csv.DictReader(handle) if r["episode_status"] not in ("prepare", "pause")]
        assert len(rows) > 500
        for row in rows:
            params = make_reward_params(
                track,
                x=float(row["X"]),
                y=float(row["Y"]),
                heading_deg=float(row["yaw"]),
                speed_mps=float(row["throttle"]),
                steering_angle_deg=float(row["steer"]),
                steps=float(row["steps"]),
                progress=float(row["progress"]),
                all_wheels_on_track=row["all_wheels_on_track"] == "True",
                is_offtrack=False,
            )
            assert default_evaluation_reward(params) == float(row["reward"]), (name, row["steps"])


@pytest.mark.parametrize(
    ("simtrace", "reward_file"),
    [
        ("console2022_training_0-iteration.csv", "awsdoc_example_1.py"),
        ("console2022_training_27-iteration.csv", "awsdoc_example_1.py"),
        ("drfc1_training_26-iteration.csv", "drfc1_follow_center_line.py"),
    ],
)
def test_centre_line_reward_reproduces_real_training_rewards(track, deepracer_data, simtrace, reward_file):
    """These runs trained with the centre-line reward: params rebuilt from X, Y give every logged reward."""
    function = load_reward_function(deepracer_data / "reward_functions" / reward_file)
    with (deepracer_data / "simtrace" / simtrace).open(newline="") as handle:
        rows = [r for r in csv.DictReader(handle) if r["episode_status"] != "prepare"]
    assert len(rows) > 400
    for row in rows:
        params = make_reward_params(
            track,
            x=float(row["X"]),
            y=float(row["Y"]),
            heading_deg=float(row["yaw"]),
            speed_mps=float(row["throttle"]),
            steering_angle_deg=float(row["steer"]),
            steps=float(row["steps"]),
            progress=float(row["progress"]),
            all_wheels_on_track=row["all_wheels_on_track"] == "True",
            is_offtrack=row["episode_status"] == "off_track",
            sim_time_s=float(row["tstamp"]),
        )
        assert function(params) == pytest.approx(float(row["reward"]), abs=1e-12), (
            simtrace,
            row["episode"],
            row["steps"],
        )


def test_a_reward_function_failing_inside_env_step_names_the_file_and_line(tmp_path, make_env):
    """The env calls the reward while the next frame renders; the error still carries the user's file and line,
    and the env can be reset and used afterwards."""
    path = tmp_path / "late_failure.py"
    path.write_text(
        "def reward_function(params):\n"
        "    if params['steps'] >= 3:\n"
        "        raise RuntimeError('bad step %d' % params['steps'])\n"
        "    return 1.0\n"
    )
    env = make_env(reward_function_path=path)
    env.reset(seed=0)
    env.step(2)  # prepare step: the reward function is not called
    env.step(2)
    with pytest.raises(RewardFunctionError) as info:
        env.step(2)
    text = str(info.value)
    assert str(path) in text and "line 3" in text and "bad step 3" in text
    observation, _ = env.reset()
    assert observation["FRONT_FACING_CAMERA"].shape == (120, 160, 1)
    _, reward, *_ = env.step(2)
    assert reward == 0.0  # the new episode's prepare step
