"""The trainer's iteration loop in-process, against a real redis-server and a local store (no rollout workers).

Episodes are pushed by the test through the same channel the workers use, so the trainer's choices can be checked
one by one: which episode trains, which is dropped, and what a failure leaves behind.
"""

from __future__ import annotations

import dataclasses
import json
import time
from pathlib import Path

import pytest

from racer.shared.config import LocalStoreSettings, ServiceSettings
from racer.shared.episode import Episode
from racer.shared.model_layout import ModelLayout
from racer.shared.policy.checkpoints import CheckpointStore
from racer.shared.redis_connection import RedisLink
from racer.shared.run_settings import RunOptions
from racer.shared.store import open_store
from racer.shared.transport.channels import RunChannel
from racer.trainer.collector import CollectTimes
from racer.trainer.precision import Precision
from racer.trainer.training_loop import Trainer, TrainerOptions
from tests.conftest import make_episode, write_custom_files

PREFIX = "loop-model"


@pytest.fixture
def custom_files(tmp_path: Path) -> Path:
    return write_custom_files(tmp_path / "custom_files", steering_deg=(-30, -15, 0, 15, 30), min_eval_trials=None)


def make_trainer(redis_settings, tmp_path: Path, custom_files: Path, **options) -> Trainer:
    """Two workers on racer_oval, base and carpet; `options` are TrainerOptions or RunOptions fields."""
    settings = ServiceSettings(redis=redis_settings, store=LocalStoreSettings(root=tmp_path / "store"))
    run_fields = {item.name for item in dataclasses.fields(RunOptions)}
    run = RunOptions(
        num_workers=2,
        track="racer_oval",
        worlds=("base", "carpet"),
        **{name: value for name, value in options.items() if name in run_fields},
    )
    trainer_options = {name: value for name, value in options.items() if name not in run_fields}
    return Trainer(settings, TrainerOptions(model_prefix=PREFIX, custom_files=custom_files, run=run, **trainer_options))


def wire_episode(iteration: int, number: int, worker_id: int, policy_version: int, seed: int) -> Episode:
    """Episode `number` of `iteration` as a worker sends it (20 steps)."""
    return make_episode(
        20,
        seed=seed,
        worker_id=worker_id,
        world="base",
        policy_version=policy_version,
        iteration=iteration,
        episode_number=number,
    )


def test_collect_trains_one_copy_of_each_episode_and_drops_stale_and_duplicate_ones(
    redis_settings, tmp_path, custom_files
):
    trainer = make_trainer(redis_settings, tmp_path, custom_files)
    assert trainer.setup() == 0
    channel = RunChannel(RedisLink(redis_settings), PREFIX)
    channel.push_episode(wire_episode(iteration=0, number=0, worker_id=0, policy_version=-1, seed=1))  # older policy
    channel.push_episode(wire_episode(iteration=0, number=0, worker_id=0, policy_version=0, seed=2))  # trains
    channel.push_episode(wire_episode(iteration=0, number=0, worker_id=1, policy_version=0, seed=3))  # replayed twice
    channel.push_episode(wire_episode(iteration=0, number=1, worker_id=1, policy_version=0, seed=4))  # trains

    got = trainer.collect(0)

    assert sorted(got) == [0, 1]
    assert got[0].episode.episode_index == 2  # the first on-policy copy of episode 0, not the replay
    assert got[1].episode.episode_index == 4
    assert channel.received_episodes(0) == {0, 1}
    # The dropped episodes are acknowledged at once; the two kept ones wait for the checkpoint.
    pending = channel.read_episodes(trainer.consumer, 0, pending=True)
    assert sorted(r.stream_id for r in pending) == sorted(r.stream_id for r in got.values())


def test_a_failed_trainer_leaves_the_run_resumable(redis_settings, tmp_path, custom_files, capsys):
    trainer = make_trainer(
        redis_settings,
        tmp_path,
        custom_files,
        collect_times=CollectTimes(episodes_timeout_s=0.5, dead_worker_grace_s=60),
    )
    with pytest.raises(TimeoutError, match=r"episodes \[0, 1\] did not arrive"):
        trainer.run()  # no worker ever delivers
    store = open_store(LocalStoreSettings(root=tmp_path / "store"))
    layout = ModelLayout(PREFIX)
    assert not store.exists(layout.finished)  # workers must keep waiting for a restarted trainer
    channel = RunChannel(RedisLink(redis_settings), PREFIX)
    assert channel.latest_iteration_announcement().kind == "iteration"
    assert "restart the trainer to resume from 0_Step-0.ckpt" in capsys.readouterr().out

    store.put_bytes(layout.finished, b"")  # as an older, finished run of the same model would have left it
    restarted = make_trainer(redis_settings, tmp_path, custom_files)
    assert restarted.setup() == 0  # resumes from checkpoint 0 ...
    assert not store.exists(layout.finished)  # ... and the model is no longer marked finished


def test_a_stop_request_finishes_the_run(redis_settings, tmp_path, custom_files):
    trainer = make_trainer(redis_settings, tmp_path, custom_files)
    trainer.stop_event.set()  # what SIGTERM / Ctrl-C do
    trainer.run()
    store = open_store(LocalStoreSettings(root=tmp_path / "store"))
    assert store.exists(ModelLayout(PREFIX).finished)
    assert RunChannel(RedisLink(redis_settings), PREFIX).latest_iteration_announcement().kind == "finished"


def test_per_worker_settings_travel_from_workers_json_to_each_worker(redis_settings, tmp_path, custom_files):
    """workers.json (like DeepRacer-for-Cloud's worker-N.env) -> training_params_<i>.yaml in the store -> the
    settings each rollout worker reads back."""
    from racer.rollout_worker.worker_files import read_training_params
    from racer.shared.worker_settings import WorkerSettings

    (custom_files / "workers.json").write_text(
        json.dumps(
            {
                "MIN_EVAL_TRIALS": 2,
                "BEST_MODEL_METRIC": "laptime",
                "RACER_EVAL_SPREAD_STARTS": True,
                "workers": [
                    {"RACER_WORLD": "concrete", "RACER_SIMAPP_DIR": "/opt/simapp/bundle"},
                    {
                        "RACER_WORLD": "wood",
                        "REVERSE_DIR": "True",
                        "START_POSITION_OFFSET": 0.25,
                        "CHANGE_START_POSITION": False,
                        "WORLD_NAME": "racer_bean",
                        "ENABLE_DOMAIN_RANDOMIZATION": "True",
                        "RACER_CAR_RANDOMIZATION": True,
                    },
                ],
            }
        )
    )
    trainer = make_trainer(redis_settings, tmp_path, custom_files)
    trainer.setup()
    store = open_store(LocalStoreSettings(root=tmp_path / "store"))
    layout = ModelLayout(PREFIX)
    read_back = []
    for worker_id in (0, 1):
        params, key = read_training_params(store, layout, worker_id)
        assert key == layout.training_params(worker_id)  # the workers differ: one file each
        read_back.append(WorkerSettings.from_training_params(params, source=key))
    assert read_back[0] == WorkerSettings(
        world="concrete",
        track="racer_oval",
        min_eval_trials=2,
        best_model_metric="laptime",
        eval_spread_starts=True,
        simapp_dir="/opt/simapp/bundle",
    )
    assert read_back[1] == WorkerSettings(
        world="wood",
        track="racer_bean",
        reverse_dir=True,
        start_position_offset=0.25,
        change_start_position=False,
        min_eval_trials=2,
        best_model_metric="laptime",
        eval_spread_starts=True,
        domain_randomization=True,
        car_randomization=True,
    )


def test_a_malformed_workers_json_names_the_file_and_line(redis_settings, tmp_path, custom_files):
    from racer.shared.user_errors import RunConfigError

    (custom_files / "workers.json").write_text('{"MIN_EVAL_TRIALS": 2,\n "workers": [{"RACER_WORLD": "wood"}\n}')
    with pytest.raises(RunConfigError, match=r"workers\.json: line 3 column 1"):
        make_trainer(redis_settings, tmp_path, custom_files).setup()
    (custom_files / "workers.json").write_text('{"workers": [{"RACER_WORLD": "gravel"}]}')
    with pytest.raises(RunConfigError, match=r"workers\.json \(worker 0\).*'gravel' is not one of"):
        make_trainer(redis_settings, tmp_path, custom_files).setup()


def test_an_announcement_lost_by_redis_is_announced_again(redis_settings, tmp_path, custom_files):
    """Redis restarted without its newest writes: the iteration's announcement is gone, so no worker would ever
    play it. The collecting trainer notices and announces it again; the workers' episodes then arrive."""
    import threading

    trainer = make_trainer(redis_settings, tmp_path, custom_files, collect_times=CollectTimes(announcement_check_s=0.3))
    trainer.setup()
    channel = RunChannel(RedisLink(redis_settings), PREFIX)
    channel.announce_iteration(0, "0_Step-0.ckpt", 2, 2)  # what Trainer.run does before collecting ...
    channel.link.do(lambda client: client.delete(channel.key("control")))  # ... and what the lost data took
    assert channel.latest_iteration_announcement() is None
    collected = {}
    collecting = threading.Thread(target=lambda: collected.update(trainer.collect(0)))
    collecting.start()
    deadline = time.monotonic() + 20
    while time.monotonic() < deadline and channel.latest_iteration_announcement() is None:
        time.sleep(0.1)
    announcement = channel.latest_iteration_announcement()
    assert announcement is not None and (announcement.kind, announcement.iteration) == ("iteration", 0)
    assert announcement.checkpoint == "0_Step-0.ckpt" and announcement.num_workers == 2
    channel.push_episode(wire_episode(iteration=0, number=0, worker_id=0, policy_version=0, seed=5))
    channel.push_episode(wire_episode(iteration=0, number=1, worker_id=1, policy_version=0, seed=6))
    collecting.join(60)
    assert sorted(collected) == [0, 1]
    announcements = channel.link.do(lambda client: client.xlen(channel.key("control")))
    assert announcements == 1  # announced again once, not on every check


def test_workers_json_names_deepracer_tracks_found_on_the_route_search_path(
    redis_settings, tmp_path, custom_files, deepracer_data, monkeypatch
):
    """WORLD_NAME as in training_params.yaml, TRACK_DIRECTION_CLOCKWISE as DeepRacer-on-AWS sends it."""
    from racer.rollout_worker.worker_files import read_training_params
    from racer.shared.user_errors import RunConfigError

    monkeypatch.setenv("RACER_ROUTES_PATH", str(deepracer_data / "routes"))
    (custom_files / "workers.json").write_text(
        json.dumps({"WORLD_NAME": "reInvent2019_track", "TRACK_DIRECTION_CLOCKWISE": "true"})
    )
    trainer = make_trainer(redis_settings, tmp_path, custom_files)
    trainer.setup()
    store = open_store(LocalStoreSettings(root=tmp_path / "store"))
    params, _ = read_training_params(store, ModelLayout(PREFIX), 1)
    assert params["WORLD_NAME"] == "reInvent2019_track_cw"

    (custom_files / "workers.json").write_text(json.dumps({"WORLD_NAME": "Nowhere_track"}))
    with pytest.raises(RunConfigError, match=f"Nowhere_track.*looked in: {deepracer_data / 'routes'}"):
        make_trainer(redis_settings, tmp_path / "other", custom_files).setup()


def test_race_settings_travel_from_train_options_and_workers_json_to_each_workers_env(
    redis_settings, tmp_path, custom_files
):
    """`--race-type` / `--race-param` for every worker, workers.json over them per worker; the store's yaml keeps
    OBJECT_POSITIONS as DeepRacer's list of "ndist,lane"; each worker's env gets its ChallengeConfig."""
    from racer.rollout_worker.worker_files import load_worker_files, training_env_config
    from racer.shared.deepracer.training_params import parse_training_params
    from racer.shared.sim.objects.challenge import ChallengeConfig, ObjectPosition

    (custom_files / "workers.json").write_text(
        json.dumps(
            {
                "COLLISION_PENALTY": 1.5,
                "workers": [
                    {},
                    {
                        "RACE_TYPE": "HEAD_TO_BOT",
                        "OBJECT_POSITIONS": [],
                        "NUMBER_OF_BOT_CARS": 2,
                        "IS_LANE_CHANGE": True,
                    },
                ],
            }
        )
    )
    challenge_params = (
        ("RACE_TYPE", "OBJECT_AVOIDANCE"),
        ("OBJECT_POSITIONS", "0.25,1;0.5,-1"),
        ("BOT_CAR_SPEED", "0.5"),
    )
    make_trainer(redis_settings, tmp_path, custom_files, challenge_params=challenge_params).setup()
    store = open_store(LocalStoreSettings(root=tmp_path / "store"))
    layout = ModelLayout(PREFIX)
    yaml_text = store.get_bytes(layout.training_params(0)).decode()
    assert list(parse_training_params(yaml_text).values["OBJECT_POSITIONS"]) == ["0.25,1", "0.5,-1"]
    assert '"OBJECT_POSITIONS":\n- "0.25,1"\n- "0.5,-1"' in yaml_text  # a YAML list, as in DeepRacer's yaml
    configs = [training_env_config(load_worker_files(store, PREFIX, i, tmp_path / f"worker-{i}")) for i in (0, 1)]
    assert configs[0].challenge == ChallengeConfig(
        race_type="OBJECT_AVOIDANCE",
        object_positions=(ObjectPosition(0.25, 1), ObjectPosition(0.5, -1)),
        bot_car_speed_mps=0.5,
    )
    assert configs[1].challenge == ChallengeConfig(
        race_type="HEAD_TO_BOT", number_of_bot_cars=2, is_lane_change=True, bot_car_speed_mps=0.5
    )
    assert configs[0].collision_penalty_s == configs[1].collision_penalty_s == 1.5


def test_the_car_profile_travels_from_train_options_and_workers_json_to_each_workers_env(
    redis_settings, tmp_path, custom_files
):
    """`--car-profile` for every worker, workers.json's RACER_CAR_PROFILE over it per worker; the model's
    training_params record each worker's car and each worker's env drives it. A bad name is refused by name."""
    from racer.rollout_worker.worker_files import load_worker_files, training_env_config
    from racer.shared.deepracer.training_params import parse_training_params
    from racer.shared.sim.car.dynamics import GAZEBO_DYNAMICS, SIMTRACE_FIT_DYNAMICS
    from racer.shared.sim.generations.catalog import DEFAULT_GENERATION, generation
    from racer.shared.user_errors import RunConfigError

    make_trainer(redis_settings, tmp_path / "default", custom_files).setup()
    store = open_store(LocalStoreSettings(root=tmp_path / "default" / "store"))
    default_car = generation(DEFAULT_GENERATION).car  # no car profile: the default generation's car
    assert training_env_config(load_worker_files(store, PREFIX, 0, tmp_path / "w")).car_dynamics == default_car

    (custom_files / "workers.json").write_text(json.dumps({"workers": [{}, {"RACER_CAR_PROFILE": "gazebo"}]}))
    make_trainer(redis_settings, tmp_path, custom_files, car_profile="simtrace-fit").setup()
    store = open_store(LocalStoreSettings(root=tmp_path / "store"))
    layout = ModelLayout(PREFIX)
    recorded = [
        parse_training_params(store.get_bytes(layout.training_params(i)).decode()).values["RACER_CAR_PROFILE"]
        for i in (0, 1)
    ]
    assert recorded == ["simtrace-fit", "gazebo"]
    configs = [training_env_config(load_worker_files(store, PREFIX, i, tmp_path / f"worker-{i}")) for i in (0, 1)]
    assert [config.car_dynamics for config in configs] == [SIMTRACE_FIT_DYNAMICS, GAZEBO_DYNAMICS]

    valid = r"unknown car profile 'f1'; choose one of gazebo, simtrace-fit"
    (custom_files / "workers.json").write_text(json.dumps({"workers": [{}, {"RACER_CAR_PROFILE": "f1"}]}))
    with pytest.raises(RunConfigError, match=rf"workers.json \(worker 1\): RACER_CAR_PROFILE: {valid}"):
        make_trainer(redis_settings, tmp_path / "bad", custom_files).setup()
    (custom_files / "workers.json").unlink()
    with pytest.raises(RunConfigError, match=rf"--car-profile.*RACER_CAR_PROFILE: {valid}"):
        make_trainer(redis_settings, tmp_path / "bad", custom_files, car_profile="f1").setup()


def test_the_generation_travels_from_train_options_and_workers_json_to_each_workers_env(
    redis_settings, tmp_path, custom_files
):
    """`--generation` for every worker, workers.json's RACER_GENERATION over it per worker: each worker's env gets
    that generation's look and car, and a RACER_CAR_PROFILE beside it replaces only the car. A bad name is refused
    by name."""
    from racer.rollout_worker.worker_files import load_worker_files, training_env_config
    from racer.shared.deepracer.training_params import parse_training_params
    from racer.shared.sim.car.dynamics import GAZEBO_DYNAMICS
    from racer.shared.sim.generations.catalog import DEFAULT_GENERATION, generation
    from racer.shared.user_errors import RunConfigError

    make_trainer(redis_settings, tmp_path / "default", custom_files).setup()
    store = open_store(LocalStoreSettings(root=tmp_path / "default" / "store"))
    assert training_env_config(load_worker_files(store, PREFIX, 0, tmp_path / "w")).generation == DEFAULT_GENERATION

    workers = [{"RACER_GENERATION": "simapp5"}, {"RACER_CAR_PROFILE": "gazebo"}]
    (custom_files / "workers.json").write_text(json.dumps({"workers": workers}))
    make_trainer(redis_settings, tmp_path, custom_files, generation="2019").setup()
    store = open_store(LocalStoreSettings(root=tmp_path / "store"))
    layout = ModelLayout(PREFIX)
    recorded = [parse_training_params(store.get_bytes(layout.training_params(i)).decode()).values for i in (0, 1)]
    assert [(values["RACER_GENERATION"], values["RACER_CAR_PROFILE"]) for values in recorded] == [
        ("simapp5", ""),
        ("2019", "gazebo"),
    ]
    configs = [training_env_config(load_worker_files(store, PREFIX, i, tmp_path / f"worker-{i}")) for i in (0, 1)]
    assert [(config.generation, config.look, config.car_dynamics) for config in configs] == [
        ("simapp5", generation("simapp5").look, generation("simapp5").car),
        ("2019", generation("2019").look, GAZEBO_DYNAMICS),
    ]

    (custom_files / "workers.json").write_text(json.dumps({"workers": [{}, {"RACER_GENERATION": "2020"}]}))
    with pytest.raises(RunConfigError, match=r"workers.json \(worker 1\): RACER_GENERATION: unknown generation '2020'"):
        make_trainer(redis_settings, tmp_path / "bad", custom_files).setup()


def test_dynamics_randomization_travels_from_train_options_and_workers_json_to_each_workers_env(
    redis_settings, tmp_path, custom_files
):
    from racer.rollout_worker.worker_files import load_worker_files, training_env_config
    from racer.shared.deepracer.training_params import parse_training_params

    make_trainer(redis_settings, tmp_path / "default", custom_files).setup()
    store = open_store(LocalStoreSettings(root=tmp_path / "default" / "store"))
    assert not training_env_config(load_worker_files(store, PREFIX, 0, tmp_path / "w")).dynamics_randomization

    (custom_files / "workers.json").write_text(json.dumps({"workers": [{}, {"RACER_DYNAMICS_RANDOMIZATION": False}]}))
    make_trainer(redis_settings, tmp_path, custom_files, dynamics_randomization=True).setup()
    store = open_store(LocalStoreSettings(root=tmp_path / "store"))
    layout = ModelLayout(PREFIX)
    recorded = [
        parse_training_params(store.get_bytes(layout.training_params(i)).decode()).values[
            "RACER_DYNAMICS_RANDOMIZATION"
        ]
        for i in (0, 1)
    ]
    assert recorded == ["True", "False"]
    configs = [training_env_config(load_worker_files(store, PREFIX, i, tmp_path / f"worker-{i}")) for i in (0, 1)]
    assert [config.dynamics_randomization for config in configs] == [True, False]


def test_a_bad_car_profile_option_is_refused_before_anything_starts(tmp_path, custom_files):
    from click.testing import CliRunner

    from racer.local.cli import train_command
    from racer.trainer.cli import trainer_command

    for command, args in (
        (train_command, ["--custom-files", str(custom_files)]),
        (trainer_command, ["--model-prefix", PREFIX, "--custom-files", str(custom_files)]),
    ):
        store = tmp_path / "store"
        result = CliRunner().invoke(command, [*args, "--car-profile", "f1"], env={"RACER_STORE": str(store)})
        assert result.exit_code == 2, result.output
        assert "--car-profile" in result.output and "'gazebo', 'simtrace-fit'" in result.output
    assert not (tmp_path / "store").exists()


def test_training_params_keys_work_or_are_refused_by_name(redis_settings, tmp_path, custom_files):
    """NUMBER_OF_RESETS, OFF_TRACK_PENALTY and NUMBER_OF_REVERSE_COUNTS reach the training env as the SimApp reads
    them; bad race keys (an unknown RACE_TYPE, a count that is no number, objects in a time trial) are a clear error
    naming the key."""
    from racer.rollout_worker.worker_files import load_worker_files, training_env_config
    from racer.shared.sim.env import DeepRacerEnv
    from racer.shared.user_errors import RunConfigError
    from tests.sim.conftest import place_front_at

    for values, message in (
        ({"RACE_TYPE": "F1"}, r"RACE_TYPE: F1 puts several trained cars on the track: run it with `racer evaluate"),
        (
            {"RACE_TYPE": "OBJECT_AVOIDANCE", "NUMBER_OF_OBSTACLES": "three"},
            r"NUMBER_OF_OBSTACLES: 'three' is not a number",
        ),
        ({"NUMBER_OF_BOT_CARS": "2"}, r"RACE_TYPE: TIME_TRIAL with .*NUMBER_OF_BOT_CARS set"),
        ({"RACE_TYPE": "HEAD_TO_BOT", "NUMBER_OF_BOT_CARS": 1, "BOT_CAR_SPEED": "0"}, r"BOT_CAR_SPEED: 0.0 m/s"),
        ({"RACE_TYPE": "OBJECT_AVOIDANCE", "OBJECT_POSITIONS": ["0.2;1"]}, r"OBJECT_POSITIONS: .* is not 'ndist,lane'"),
    ):
        (custom_files / "workers.json").write_text(json.dumps(values))
        with pytest.raises(RunConfigError, match=rf"workers.json \(worker 0\): {message}"):
            make_trainer(redis_settings, tmp_path / "bad", custom_files).setup()

    (custom_files / "workers.json").write_text(
        json.dumps(
            {
                "NUMBER_OF_RESETS": 2,
                "OFF_TRACK_PENALTY": "1.0",
                "NUMBER_OF_REVERSE_COUNTS": "5",
                "RACE_TYPE": "TIME_TRIAL",
            }
        )
    )
    make_trainer(redis_settings, tmp_path, custom_files).setup()
    store = open_store(LocalStoreSettings(root=tmp_path / "store"))
    run = load_worker_files(store, PREFIX, 1, tmp_path / "worker-1")
    config = training_env_config(run)
    assert (config.number_of_resets, config.off_track_penalty_s, config.number_of_reverse_counts) == (2, 1.0, 5)
    env = DeepRacerEnv(config)
    try:
        env.reset(seed=0)
        env.step(0)
        place_front_at(env, 0.5, backwards=True)
        statuses = [env.step(2)[-1]["episode_status"] for _ in range(7)]
    finally:
        env.close()
    assert statuses.index("reversed") == 5  # 5 steps of decreasing progress (the SimApp's default would be 15)
    assert statuses[6] == "pause"  # with resets left it pauses for OFF_TRACK_PENALTY and goes on


def test_an_episode_claimed_by_a_worker_killed_while_holding_it_is_played_by_another(
    redis_settings, tmp_path, custom_files
):
    """Claimed work: a worker process claims episode 1 (its own share) and is killed -9 before delivering it. Once its
    heartbeat is gone the claim goes back to the queue; the live worker, done with its own share, claims and
    delivers it. The iteration gets exactly episodes 0 and 1, nothing lost, nothing twice."""
    import signal
    import subprocess
    import sys
    import threading

    trainer = make_trainer(redis_settings, tmp_path, custom_files, collect_times=CollectTimes(dead_worker_grace_s=0.5))
    assert trainer.setup() == 0
    trainer._announce(0, trainer.checkpoints.latest_name())
    channel = RunChannel(RedisLink(redis_settings), PREFIX)
    victim_code = (
        "import sys, time\n"
        "from racer.shared.config import RedisSettings\n"
        "from racer.shared.redis_connection import RedisLink\n"
        "from racer.shared.transport.channels import RunChannel\n"
        f"channel = RunChannel(RedisLink(RedisSettings(url={redis_settings.url!r})), {PREFIX!r})\n"
        "channel.beat(1, {'state': 'playing'})\n"
        "print(channel.claim_own(0, 1), flush=True)\n"
        "time.sleep(600)\n"
    )
    victim = subprocess.Popen([sys.executable, "-c", victim_code], stdout=subprocess.PIPE, text=True)
    assert victim.stdout.readline().strip() == "1"  # it holds episode 1
    victim.send_signal(signal.SIGKILL)
    victim.wait()
    channel.link.do(lambda r: r.delete(channel.key("heartbeat:1")))  # its heartbeat lapses (TTL cut short)

    delivered = []
    stop = threading.Event()

    def live_worker() -> None:  # worker 0: its own episode, then whatever goes back to the queue
        while not stop.is_set():
            channel.beat(0, {"state": "playing"})
            number = channel.claim_own(0, 0)
            if number is None:
                number = channel.claim_other(0, 0, 2, channel.live_workers())
            if number is None:
                time.sleep(0.1)
                continue
            delivered.append(number)
            channel.deliver_episode(
                wire_episode(iteration=0, number=number, worker_id=0, policy_version=0, seed=10 + number)
            )

    thread = threading.Thread(target=live_worker, daemon=True)
    thread.start()
    try:
        got = trainer.collect(0)
    finally:
        stop.set()
        thread.join(5)
    assert sorted(got) == [0, 1]
    assert delivered == [0, 1]
    assert {received.episode.worker_id for received in got.values()} == {0}
    queued, claimed = channel.queued_and_claimed(0, 2)
    assert not queued and not any(claimed.values())


def test_a_finished_worker_claims_episodes_of_a_slower_one_only_after_its_own(redis_settings):
    channel = RunChannel(RedisLink(redis_settings), "claims-model")
    assert channel.open_episodes(3, episodes=6, num_workers=2)
    assert not channel.open_episodes(3, episodes=6, num_workers=2)  # an announcement repeated: queued once
    assert [channel.claim_own(3, 0) for _ in range(4)] == [0, 2, 4, None]  # worker 0's DeepRacer share
    assert channel.claim_own(3, 1) == 1
    assert channel.claim_other(3, 0, 2, live={0, 1}) == 5  # the last of the longest queue
    assert channel.claim_other(3, 0, 2, live={0, 1}) is None  # worker 1 keeps one episode of its own: it is alive
    assert channel.claim_other(3, 0, 2, live={0}) == 3  # no heartbeat: its last one is taken too
    assert channel.claim_other(3, 0, 2) is None
    assert channel.release_claims(3, 1) == [1]
    assert channel.queued_and_claimed(3, 2) == ({1}, {0: {0, 2, 4, 5, 3}, 1: set()})


@pytest.mark.parametrize("precision", [None, Precision.BF16], ids=["default", "bf16"])
def test_the_precision_reaches_the_learner_and_every_checkpoints_manifest(
    redis_settings, tmp_path, custom_files, precision
):
    """fp32 unless asked: a default that followed the CPU changed what runs learnt (docs/benchmarks.md)."""
    options = {} if precision is None else {"precision": precision}
    trainer = make_trainer(redis_settings, tmp_path, custom_files, **options)
    trainer.setup()
    expected = precision or Precision.FP32
    assert trainer.learner.tower_dtype == expected.tower_dtype
    store = CheckpointStore(open_store(LocalStoreSettings(root=tmp_path / "store")), PREFIX)
    assert store.read_info(store.names()[-1]).extra["trainer_precision"] == expected.value


def test_overlap_trains_episodes_one_version_behind_requeues_older_ones_and_keeps_early_ones(
    redis_settings, tmp_path, custom_files
):
    trainer = make_trainer(redis_settings, tmp_path, custom_files, overlap=True)
    assert trainer.setup() == 0
    channel = RunChannel(RedisLink(redis_settings), PREFIX)
    # Iteration 1, queued while iteration 0 trained: played by checkpoint 0 or, once the workers hold it, 1.
    channel.push_episode(wire_episode(iteration=1, number=0, worker_id=0, policy_version=0, seed=1))  # one behind
    channel.push_episode(wire_episode(iteration=1, number=1, worker_id=1, policy_version=-1, seed=2))  # two behind
    channel.push_episode(wire_episode(iteration=2, number=0, worker_id=0, policy_version=1, seed=3))  # the next one's
    channel.push_episode(wire_episode(iteration=1, number=1, worker_id=1, policy_version=1, seed=4))  # on-policy

    got = trainer.collect(1)

    assert {number: item.episode.episode_index for number, item in got.items()} == {0: 1, 1: 4}
    queued, _claimed = channel.queued_and_claimed(1, 2)
    assert queued == {1}  # the episode two versions behind went back to the queue at once: E still train
    assert [item.episode.episode_index for item in trainer.collector.early] == [3]

    channel.push_episode(wire_episode(iteration=2, number=1, worker_id=1, policy_version=2, seed=5))
    got = trainer.collect(2)
    assert {number: item.episode.episode_index for number, item in got.items()} == {0: 3, 1: 5}
