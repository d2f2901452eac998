"""`python -m benchmarks race-pace`: the lap figures it reads from checkpoint evaluations, where the time went, its options,
and the JSON line of a very short real run."""

from __future__ import annotations

import json
import tempfile

import numpy as np
import pytest
from click.testing import CliRunner

from benchmarks.race_pace import race_pace_command
from benchmarks.race_pace_laps import CheckpointLaps, best_average, best_lap, lap_to_draw, pace_figures
from benchmarks.race_pace_picture import DrivenLap, draw_pace
from benchmarks.time_shares import time_shares
from racer.racing_line import CarLimits, racing_line
from racer.shared import worker_phases
from racer.shared.sim.car.dynamics import CAR_DYNAMICS
from racer.shared.sim.tracks.track import Track


def record(checkpoint: str, laps: list[float | None], statuses: list[str], steps: int = 100) -> dict:
    """An `evaluations` stream record as worker 0 publishes it with RACER_EVAL_CONTINUOUS (a lap that did not finish
    got a third of the way)."""
    return {
        "checkpoint": checkpoint,
        "env_steps_total": steps,
        "lap_times_s": laps,
        "statuses": statuses,
        "progresses": [100.0 if status == "lap_complete" else 33.3 for status in statuses],
        "continuous": True,
    }


DONE = "lap_complete"
SHORT_RUN_MINUTES = 1.0
"""The short run's limit: its worker must start and judge a first checkpoint inside it. Half a minute was too little
on a loaded 2-core machine (the suite's first phase: the worker took 48 s to start and judge checkpoint 0, late)."""
RUNS = [
    (0.5, record("1.ckpt", [None], ["off_track"])),
    (1.0, record("2.ckpt", [8.0, 7.5, None], [DONE, DONE, "off_track"])),
    (1.5, record("3.ckpt", [7.9, 7.2, 7.3], [DONE, DONE, DONE])),
    (2.0, record("4.ckpt", [7.8, 7.2, 7.1], [DONE, DONE, DONE])),
    (2.5, record("5.ckpt", [7.95, 7.3, 7.25], [DONE, DONE, DONE])),
    (3.0, record("6.ckpt", [7.2, 7.3, None], [DONE, DONE, "in_progress"])),
]


def evaluations() -> list[CheckpointLaps]:
    return [CheckpointLaps.from_record(run, minutes) for minutes, run in RUNS]


def test_best_lap_and_best_average_are_first_reached_where_the_laps_say():
    runs = evaluations()
    lap = best_lap(runs)
    assert (lap.value_s, lap.checkpoint, lap.minutes) == (7.1, "4.ckpt", 2.0)
    average = best_average(runs)
    assert average.checkpoint == "4.ckpt" and average.value_s == pytest.approx((7.8 + 7.2 + 7.1) / 3)
    assert (best_lap(runs[:3]).value_s, best_lap(runs[:3]).checkpoint) == (7.2, "3.ckpt")
    assert best_average(runs[:2]) is None  # no evaluation yet drove 3 laps without a reset


def test_the_summary_compares_the_last_checkpoint_and_counts_resets_but_not_the_step_cap():
    pace = pace_figures(evaluations())
    assert pace["last_checkpoint"] == "6.ckpt" and pace["last_three_lap_average_s"] is None
    assert pace["evaluations_ended_by_a_reset"] == 2  # 1.ckpt and 2.ckpt; 6.ckpt was capped
    assert pace["laps_completed"] == 0 + 2 + 3 + 3 + 3 + 2
    curve = pace["curve"]
    assert [point["best_lap_s"] for point in curve] == [None, 7.5, 7.2, 7.1, 7.1, 7.1]
    assert all(a["minutes"] <= b["minutes"] for a, b in zip(curve, curve[1:], strict=False))
    up_to_five = pace_figures(evaluations()[:5])
    expected = (7.95 + 7.3 + 7.25) / ((7.8 + 7.2 + 7.1) / 3) / 3
    assert up_to_five["last_to_best_average"] == pytest.approx(expected, abs=1e-4)


def test_the_picture_drives_the_best_lap_or_before_any_the_furthest_attempt():
    target = lap_to_draw(evaluations())
    assert (target.checkpoint, target.lap_index, target.lap_time_s) == ("4.ckpt", 2, 7.1)
    early = [
        CheckpointLaps.from_record(record("1.ckpt", [None], ["off_track"]) | {"progresses": [12.0]}, 0.5),
        CheckpointLaps.from_record(record("2.ckpt", [None], ["off_track"]) | {"progresses": [31.5]}, 1.0),
        CheckpointLaps.from_record(record("3.ckpt", [None], ["off_track"]) | {"progresses": [20.0]}, 1.5),
    ]
    target = lap_to_draw(early)
    assert (target.checkpoint, target.lap_index, target.lap_time_s, target.progress) == ("2.ckpt", 0, None, 31.5)
    assert lap_to_draw([]) is None


def test_an_evaluation_without_consecutive_laps_is_refused_naming_the_setting():
    with pytest.raises(ValueError, match="RACER_EVAL_CONTINUOUS"):
        CheckpointLaps.from_record({"checkpoint": "1.ckpt", "trials": 3, "laps_completed": 0}, 1.0)


def test_time_shares_add_the_trainer_and_the_workers_phases():
    phases = dict.fromkeys(worker_phases.PHASES, 0.0)
    records = [
        {"elapsed_s": 50.0, "update_s": 20.0, "rollout_s": 25.0, "worker_phases_s": {"0": {**phases, "playing": 10.0}}},
        {
            "elapsed_s": 100.0,
            "update_s": 30.0,
            "rollout_s": 15.0,
            "worker_phases_s": {
                "0": {**phases, "playing": 40.0, "waiting": 40.0, "evaluating": 20.0},
                "1": {**phases, "playing": 50.0, "waiting": 50.0},
            },
        },
    ]
    shares = time_shares(records, cpu_s=150.0, wall_s=100.0, cores=2)
    assert shares["trainer"] == {"wall_s": 100.0, "updating": 0.5, "waiting_for_episodes": 0.4, "other": 0.1}
    workers = shares["workers"]
    assert workers["workers"] == 2 and workers["wall_s"] == 200.0
    assert workers["simulating_training_episodes"] == 0.45 and workers["simulating_evaluations"] == 0.1
    assert workers["waiting_for_a_checkpoint"] == 0.45
    assert shares["cpu_busy"] == 0.75


def test_the_picture_draws_the_line_and_a_lap(tmp_path):
    track = Track.load("racer_oval")
    line = racing_line(track, CarLimits.of_car(CAR_DYNAMICS["gazebo"]), control_spacings_m=(0.8,))
    angles = np.linspace(0, 2 * np.pi, 120)
    lap = DrivenLap("3.ckpt", 1, np.column_stack((2.0 * np.cos(angles), np.sin(angles))), 8.0, 100.0)
    assert lap.speeds_mps.shape == (119,) and np.all(lap.speeds_mps > 0)
    path = draw_pace(track, line, lap, "test", tmp_path / "pace.png")
    assert path.stat().st_size > 10_000


@pytest.mark.parametrize(
    ("args", "named"),
    [
        (["--minutes", "0"], "--minutes"),
        (["--hyperparameter", "discount_factor=2"], "discount_factor"),
        (["--action-space", "both"], "--action-space"),
        (["--generation", "2030"], "--generation"),
    ],
)
def test_bad_options_are_refused_before_anything_starts(tmp_path, monkeypatch, args, named):
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))  # where the command would make its run folder
    result = CliRunner().invoke(race_pace_command, ["--track", "racer_oval", *args])
    assert result.exit_code == 2, result.output
    assert named in result.output
    assert list(tmp_path.iterdir()) == []


def test_bound_only_prints_the_bound_of_worker_0s_car_and_world():
    result = CliRunner().invoke(race_pace_command, ["--track", "racer_oval", "--bound-only", "--generation", "2019"])
    assert result.exit_code == 0, result.output
    line = json.loads(result.stdout.strip().splitlines()[-1])
    assert line["car_profile"] == "gazebo" and line["world"] == "base"  # the 2019 generation's car
    assert line["recipe"] == "racer recipe racer_oval --action-space discrete"  # racer recipe's folder by default
    bound = line["bound"]
    assert bound["flying_lap_s"] < bound["centre_line_lap_s"]
    assert bound["three_lap_average_s"] > bound["flying_lap_s"]  # the first lap starts from rest
    assert "best_lap" not in line


@pytest.mark.slow
def test_a_short_run_prints_one_json_line_with_every_figure(tmp_path, monkeypatch):
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    args = ["--track", "racer_oval", "--minutes", str(SHORT_RUN_MINUTES), "--workers", "1"]
    args += ["--hyperparameter", "num_episodes_between_training=2", "--picture", str(tmp_path / "pace.png")]
    result = CliRunner().invoke(race_pace_command, args)
    assert result.exit_code == 0, result.output
    lines = result.stdout.strip().splitlines()
    assert len(lines) == 1  # the run's progress went to stderr
    line = json.loads(lines[0])
    assert line["track"] == "racer_oval" and line["minutes"] == SHORT_RUN_MINUTES and line["workers"] == 1
    assert line["overlap"] is False  # strict unless --overlap (or RACER_OVERLAP)
    assert line["evaluations"] >= 1 and len(line["curve"]) == line["evaluations"]
    assert all(len(checkpoint["laps_s"]) <= 3 for checkpoint in line["checkpoints"])
    assert all(point["minutes"] <= SHORT_RUN_MINUTES for point in line["curve"])
    assert line["hyperparameters"]["num_episodes_between_training"] == 2
    assert line["preset"] == {"anneal_lr": True}  # racer recipe's folder: the rate falls to 0 at the time limit
    rates, lr = line["learning_rate"], line["hyperparameters"]["lr"]
    assert lr > rates["first"] == rates["highest"] > rates["last"] == rates["lowest"] >= 0
    assert 0 < line["kl_divergence"]["median"] <= line["kl_divergence"]["highest"]  # every update moved the policy
    shares = line["time_shares"]
    assert shares["workers"]["workers"] == 1
    assert sum(v for k, v in shares["workers"].items() if k not in ("workers", "wall_s")) == pytest.approx(1, abs=0.01)
    assert 0 < shares["trainer"]["updating"] < 1
    assert (tmp_path / "pace.png").stat().st_size > 10_000
    drawn = line["picture_lap"]  # the best lap, or before any the furthest drive, driven again from its checkpoint
    assert drawn["checkpoint"] in {checkpoint["checkpoint"] for checkpoint in line["checkpoints"]}
    assert drawn["matches_the_evaluation"], drawn  # racer's simulator is deterministic: the same drive again
    assert not [p for p in tmp_path.iterdir() if p.name.startswith("racer-race-pace-")]  # the run's folder is gone
