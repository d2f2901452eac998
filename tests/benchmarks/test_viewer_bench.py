"""`python -m benchmarks viewer`: its arithmetic (each load-on iteration against its load-off neighbours, steps per phase)
and its loads other than the browser switching the frames on and off on a real redis-server and viewer."""

import time

from click.testing import CliRunner

from benchmarks.viewer import (
    _bench_hyperparameters,
    _paired_ratios,
    _phase_steps,
    _write_custom_files,
    viewer_bench_command,
)
from benchmarks.viewer_loads import PagePolls, WatchingOnly
from racer.shared.deepracer.hyperparameters import load_hyperparameters
from racer.shared.redis_connection import RedisLink
from racer.shared.store import LocalStore
from racer.shared.transport.frames import FrameChannel
from racer.viewer.app import create_app
from racer.viewer.live import LiveRun
from racer.viewer.run_reader import RunLocation, RunReader
from tests.viewer.conftest import ServedApp
from tests.viewer.frames import publish_frame


def records(rates: list[float], on: list[bool], steps: list[int]) -> list[dict]:
    total, rows = 0, []
    for rate, load_on, played in zip(rates, on, steps, strict=True):
        total += played
        rows.append({"experience_steps_per_s": rate, "load_on": load_on, "env_steps_total": total})
    return rows


def test_each_load_on_iteration_is_compared_with_its_load_off_neighbours():
    rows = records([100.0, 90.0, 120.0, 99.0, 110.0], [False, True, False, True, False], [10] * 5)
    assert _paired_ratios(rows) == [90.0 / 110.0, 99.0 / 115.0]
    # at the edge only one neighbour exists; two load-on iterations in a row are not neighbours of each other
    rows = records([100.0, 80.0, 70.0], [False, True, True], [10] * 3)
    assert _paired_ratios(rows) == [0.8]


def test_steps_per_phase_come_from_the_running_total_after_the_warm_up():
    rows = records([1.0] * 5, [False, False, True, False, True], [7, 11, 13, 17, 19])
    assert _phase_steps(rows, warmup_iterations=2, on=True) == 13 + 19
    assert _phase_steps(rows, warmup_iterations=2, on=False) == 17


def test_the_bench_model_trains_three_epochs_with_the_learning_rate_it_is_given(tmp_path):
    _write_custom_files(tmp_path / "frozen", _bench_hyperparameters(episodes_per_iteration=48, learning_rate=1e-8))
    hyperparameters, unknown = load_hyperparameters(tmp_path / "frozen" / "hyperparameters.json")
    assert (hyperparameters.lr, hyperparameters.num_episodes_between_training, unknown) == (1e-8, 48, [])
    assert hyperparameters.num_epochs == 3  # the fewest allowed: the update is not measured, a short one leaves room


def wait_until(check, timeout_s: float = 10.0) -> bool:
    deadline = time.monotonic() + timeout_s
    while not check():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.1)
    return True


def test_the_watching_load_makes_workers_publish_only_while_on(redis_settings):
    frames = FrameChannel(RedisLink(redis_settings), "bench-load")
    load = WatchingOnly(frames)
    try:
        assert not frames.is_watched(0)
        load.start()
        assert frames.is_watched(0)
        load.stop()
        frames.clear_watching()
        time.sleep(1.5)  # its thread renews nothing once stopped
        assert not frames.is_watched(0)
    finally:
        load.quit()


def test_the_polling_load_asks_for_frames_and_reads_them(tmp_path, redis_settings):
    store = LocalStore(tmp_path / "store")
    store.put_bytes("bench-load/training_params.yaml", b"WORLD_NAME: racer_oval\nNUM_WORKERS: '1'\n")
    frames = FrameChannel(RedisLink(redis_settings), "bench-load")
    publish_frame(frames, 0, seq=1, shade=90)
    app = create_app(RunReader(RunLocation(store, "bench-load")), LiveRun(redis_settings, "bench-load"))
    with ServedApp(app) as served:
        load = PagePolls(served.url + "/")
        try:
            time.sleep(1.2)
            assert not frames.is_watched(0)  # off: no request
            load.start()
            assert wait_until(lambda: frames.is_watched(0) and load.cpu_s() > 0)
        finally:
            load.quit()


def test_a_value_deepracer_refuses_stops_the_bench_before_anything_starts():
    result = CliRunner().invoke(viewer_bench_command, ["--episodes-per-iteration", "128", "--load", "frames"])
    assert result.exit_code == 1
    assert "num_episodes_between_training: 128 is out of range" in result.output
