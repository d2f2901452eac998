"""How far a run is and how long it has left (racer.shared.run_progress): the estimator, the trainer that measures
it after each iteration, and `racer train`'s lines that print it (through a real redis-server)."""

from __future__ import annotations

import json

import pytest

from racer.local.progress import ProgressDisplay
from racer.shared.model_layout import ModelLayout
from racer.shared.redis_connection import RedisLink
from racer.shared.run_progress import RunPace, RunProgress, StopCondition, clock
from racer.shared.store import LocalStore
from racer.shared.transport.channels import RunChannel
from tests.conftest import write_custom_files
from tests.trainer.test_training_loop import PREFIX, make_trainer, wire_episode


@pytest.fixture
def custom_files(tmp_path):
    return write_custom_files(tmp_path / "custom_files", steering_deg=(-30, -15, 0, 15, 30), min_eval_trials=None)


def test_clock_reads_as_minutes_and_hours():
    assert [clock(s) for s in (0, 59.9, 61, 754.2, 3600, 4000)] == [
        "0:00",
        "0:59",
        "1:01",
        "12:34",
        "1:00:00",
        "1:06:40",
    ]


def test_the_episode_limit_is_reached_after_whole_iterations_at_the_recent_pace():
    pace = RunPace(StopCondition(max_episodes=100, episodes_per_iteration=20))
    first = pace.after_iteration(0, elapsed_s=70.0, episodes=20, measured_at=1000.0)
    # One iteration known: its length counts from the trainer's start (set-up included), 4 iterations to go.
    assert first.stops_by == "episodes" and first.remaining_s == pytest.approx(4 * 70.0)
    second = pace.after_iteration(1, elapsed_s=120.0, episodes=40, measured_at=1050.0)
    assert second.remaining_s == pytest.approx(3 * 50.0)  # set-up left out: the pace of iteration 1 alone
    assert second.fraction_done == pytest.approx(0.4)
    assert "40/100 episodes, about 2:30 left" == second.describe()
    # Played episodes beyond a multiple of the iteration (DeepRacer's memory cap drops some) round up to an iteration.
    third = pace.after_iteration(2, elapsed_s=150.0, episodes=61, measured_at=1080.0)
    assert third.remaining_s == pytest.approx(2 * 40.0)  # ceil(39 / 20) iterations at (150 - 70) / 2 s


def test_the_pace_follows_the_last_iterations_only():
    pace = RunPace(StopCondition(max_episodes=1000, episodes_per_iteration=10), window=2)
    ends = [10.0, 20.0, 30.0, 130.0, 230.0]  # the run slowed down from 10 to 100 s per iteration
    for iteration, end in enumerate(ends):
        progress = pace.after_iteration(iteration, elapsed_s=end, episodes=10 * (iteration + 1), measured_at=end)
    assert pace.seconds_per_iteration() == pytest.approx(100.0)
    assert progress.remaining_s == pytest.approx(95 * 100.0)


def test_the_sooner_limit_stops_the_run():
    pace = RunPace(StopCondition(max_episodes=1000, max_minutes=10, episodes_per_iteration=10))
    by_time = pace.after_iteration(0, elapsed_s=200.0, episodes=10, measured_at=0.0)
    assert by_time.stops_by == "time" and by_time.remaining_s == pytest.approx(400.0)
    assert by_time.fraction_done == pytest.approx(200 / 600)
    assert by_time.describe() == "3:20 of 10:00, about 6:40 left"

    short = RunPace(StopCondition(max_episodes=30, max_minutes=10, episodes_per_iteration=10))
    short.after_iteration(0, elapsed_s=20.0, episodes=10, measured_at=0.0)
    by_episodes = short.after_iteration(1, elapsed_s=40.0, episodes=20, measured_at=0.0)
    assert by_episodes.stops_by == "episodes" and by_episodes.remaining_s == pytest.approx(20.0)

    late = pace.after_iteration(1, elapsed_s=700.0, episodes=20, measured_at=0.0)  # past the limit, still stopping
    assert late.remaining_s == 0.0 and late.fraction_done == 1.0
    assert late.describe() == "11:40 of 10:00, stopping"


def test_a_measurement_counts_on_to_a_later_moment_and_travels_as_json():
    pace = RunPace(StopCondition(max_episodes=1000, max_minutes=10, episodes_per_iteration=10))
    measured = pace.after_iteration(3, elapsed_s=200.0, episodes=40, measured_at=5000.0)
    later = measured.at(5030.5)
    assert later.elapsed_s == pytest.approx(230.5) and later.remaining_s == pytest.approx(369.5)
    assert measured.at(4000.0) == measured  # a clock behind the measurement changes nothing
    assert measured.at(99_999.0).remaining_s == 0.0
    back = RunProgress.from_dict(json.loads(json.dumps(measured.to_dict())))
    assert back == measured


def test_racer_trains_lines_end_with_the_trainers_figures(redis_settings):
    channel = RunChannel(RedisLink(redis_settings), "display-model")
    lines: list[str] = []
    display = ProgressDisplay(channel, num_workers=1, started=0.0, echo=lambda text, err=False: lines.append(text))
    pace = RunPace(StopCondition(max_episodes=1000, max_minutes=10, episodes_per_iteration=2))
    record = {
        "iteration": 4,
        "episodes": 2,
        "env_steps_total": 840,
        "mean_reward": 12.5,
        "mean_progress": 31.0,
        "completion_rate": 0.5,
        "experience_steps_per_s": 61.0,
        "worlds": {},
        "progress": pace.after_iteration(4, elapsed_s=75.0, episodes=10).to_dict(),
    }
    channel.publish("iterations", record)
    channel.publish("iterations", {**record, "iteration": 5, "progress": None})  # a trainer of an older racer
    display.poll()
    iteration_lines = [line for line in lines if "] iteration" in line]
    assert iteration_lines[0].endswith("| 1:15 of 10:00, about 8:45 left"), iteration_lines
    assert "left" not in iteration_lines[1]
    # The status line (every 30 s) counts on from the newest figures it has.
    display.progress = RunProgress.from_dict(record["progress"])
    display.last_status = 0.0
    display.poll()
    status = [line for line in lines if "] workers" in line][-1]
    assert "of 10:00, about" in status and "left" in status


def test_the_trainer_records_its_progress_with_each_iteration(redis_settings, tmp_path, custom_files):
    """Two real iterations of the trainer in-process: the iterations log carries the episodes played, the stop
    condition (the hyperparameters' 2 episodes per iteration, --max-episodes 6, --max-minutes 30) and an estimate."""
    trainer = make_trainer(redis_settings, tmp_path, custom_files, max_episodes=6, max_minutes=30.0)
    trainer.setup()
    channel = RunChannel(RedisLink(redis_settings), PREFIX)
    for iteration in (0, 1):
        channel.push_episode(
            wire_episode(iteration, number=0, worker_id=0, policy_version=iteration, seed=10 * iteration)
        )
        channel.push_episode(
            wire_episode(iteration, number=1, worker_id=1, policy_version=iteration, seed=10 * iteration + 1)
        )
        trainer._iterate(iteration)
    trainer._finish_previous()  # iteration 1's line: written after the next announcement, or before .finished
    log = LocalStore(tmp_path / "store").get_bytes(ModelLayout(PREFIX).iterations_log).decode().splitlines()
    first, second = (RunProgress.from_dict(json.loads(line)["progress"]) for line in log)
    assert (first.iteration, first.episodes, second.iteration, second.episodes) == (0, 2, 1, 4)
    assert second.max_episodes == 6 and second.max_minutes == 30.0 and second.stops_by == "episodes"
    assert 0 < first.elapsed_s < second.elapsed_s
    # One iteration to go at the pace of iteration 1 (the time between the two measurements).
    assert second.remaining_s == pytest.approx(second.elapsed_s - first.elapsed_s, abs=0.01)
