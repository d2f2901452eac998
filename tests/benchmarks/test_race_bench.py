"""`python -m benchmarks race` at its smallest: the two Gazebo checkpoints, a racer model given with --entrant and the bench's
broken folder, one lap each, timed as a race with two workers and as `racer evaluate` one after another; the board
must be full."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml
from click.testing import CliRunner

from benchmarks.race import race_bench_command, sequential_laps
from racer.shared.store import LocalStore
from tests.race.test_real_race import save_model


@pytest.mark.slow
def test_smallest_race_bench_prints_both_rates_and_a_full_board(tmp_path, deepracer_data):
    store = LocalStore(tmp_path / "racer-data")
    save_model(store, "fresh_model", 0)  # untrained: off the track within seconds (--quick: maxResets 0)
    fresh = str(tmp_path / "racer-data" / "fresh_model")
    args = ["--quick", "--entrants", "3", "--workers", "2", "--entrant", fresh, "--data", str(deepracer_data)]
    result = CliRunner().invoke(race_bench_command, args, catch_exceptions=False)
    assert result.exit_code == 0, result.output
    report = json.loads([line for line in result.stdout.splitlines() if line.startswith("{")][-1])
    # every model given races: 2 Gazebo checkpoints + fresh-model + the broken folder, though --entrants 3
    assert report["benchmark"] == "race" and report["entrants"] == 4 and report["workers"] == 2
    assert report["track"] == "reinvent_base" and report["laps"] == 1
    assert report["race_s"] > 0 and report["sequential_s"] > 0
    assert report["race_entrants_per_min"] == pytest.approx(4 * 60 / report["race_s"], rel=0.02)
    assert report["ratio"] == pytest.approx(report["sequential_s"] / report["race_s"], rel=0.02)
    board = report["board"]
    assert board["full"] and board["rows"] == 4
    assert board["broken_row"]["dnfReason"] and board["broken_row"]["errorCode"]
    assert board["entrants_with_three_videos"] == 3  # videos on: in-car, top and follow of every car that raced
    assert board["ranked"] == 2  # each Gazebo checkpoint laps re:Invent 2018 in about 10 s; the fresh model does not
    assert report["same_laps_as_racer_evaluate"]  # one seed: the race's laps are racer evaluate's


def test_multi_car_part_runs_each_race_twice_and_compares_the_boards(tmp_path, monkeypatch):
    """`--multi-car` without the simulator: each `racer race` call writes the board a race of its field would."""
    from benchmarks import race_multi_car

    store = tmp_path / "store"
    for seed, model in enumerate(("alpha", "beta")):
        save_model(LocalStore(store), model, seed)
    (tmp_path / "logs").mkdir()
    calls = []

    def fake_race(command, log_path, env):
        race_file, *rest = command[command.index("race") + 1 :]
        names = rest[: rest.index("--seed")]
        out = Path(rest[rest.index("--out") + 1])
        (out / "videos").mkdir(parents=True)
        (out / "videos" / "all-cars-topview.mp4").write_bytes(b"mp4")
        rows = [
            {"entrant": name, "collisionCount": index, "multiCar": {"finishingPlace": len(names) - index}}
            for index, name in enumerate(names)
        ]
        (out / "leaderboard.json").write_text(json.dumps({"leaderboard": rows}))
        (out / "leaderboard.csv").write_text("".join(f"{name}\n" for name in names))
        calls.append((Path(race_file).stem, names))
        return 0

    monkeypatch.setattr(race_multi_car, "run_logged", fake_race)
    route = tmp_path / "routes" / "reinvent_base.npy"  # only named in the race files: the fake race reads none
    report = race_multi_car.multi_car_races(
        tmp_path, ["alpha", "beta"], route, seed=0, quick=False, env={"RACER_STORE": str(store)}
    )
    assert report["laps"] == 3
    assert [stem for stem, _ in calls] == ["bench-h2m", "bench-h2m", "bench-f1", "bench-f1"]
    h2m, f1 = report["head_to_model"], report["f1"]
    assert h2m["entrants"] == ["alpha", "beta"] and f1["entrants"] == ["alpha", "beta", "alpha-2", "beta-2"]
    assert (store / "beta-2" / "model").is_dir()  # re-entries race from prefixes of their own
    for race in (h2m, f1):
        assert race["complete"] and race["identical_boards"] and race["top_view_video"]
        assert len(race["wall_s"]) == 2
    assert f1["crashes"] == {"alpha": 0, "beta": 1, "alpha-2": 2, "beta-2": 3}
    assert f1["finishing_order"] == ["beta-2", "alpha-2", "beta", "alpha"]
    race_file = yaml.safe_load((tmp_path / "bench-f1.yaml").read_text())
    assert race_file["raceType"] == "F1" and race_file["submissionTerminationConditions"]["maximumLaps"] == 3
    assert race_file["trackConfig"]["trackId"] == str(route)


def test_an_entrant_copy_holds_only_the_raced_checkpoint(tmp_path):
    """Two checkpoints with optimiser state, the first the best: the copy has that one's weights and ONNX only, and
    an evaluation's loading path finds and loads it."""
    import torch

    from benchmarks.race_field import copy_raced_checkpoint
    from racer.shared.policy.checkpoints import CheckpointStore
    from racer.shared.policy.networks import build_actor_critic
    from racer.shared.sim.config import DEFAULT_MODEL_METADATA

    store = LocalStore(tmp_path / "store")
    checkpoints = CheckpointStore(store, "fast")
    checkpoints.put_model_metadata(DEFAULT_MODEL_METADATA)
    network = build_actor_critic(DEFAULT_MODEL_METADATA)
    optimizer = torch.optim.Adam(network.parameters())
    first = checkpoints.save(0, 100, network, optimizer, model_metadata=DEFAULT_MODEL_METADATA)
    checkpoints.record_evaluation(first, 100.0, 1.0)
    second = checkpoints.save(1, 200, network, optimizer, model_metadata=DEFAULT_MODEL_METADATA)
    checkpoints.record_evaluation(second, 40.0, 2.0)

    copy_raced_checkpoint(tmp_path / "store" / "fast" / "model", tmp_path / "store" / "fast-2" / "model")
    copied = sorted(path.name for path in (tmp_path / "store" / "fast-2" / "model").iterdir())
    assert not any(second in name or "optimizer" in name or name == "model_1.onnx" for name in copied), copied
    assert "model_0.onnx" in copied and f"{first}.json" in copied and "model_metadata.json" in copied
    copy = CheckpointStore(store, "fast-2")
    assert copy.select("best") == first
    copy.load_inference_policy(first)


def test_baseline_laps_come_from_either_evaluation_metrics_key(tmp_path):
    """The newest evaluation's laps, whether its metrics sit at DeepRacer-for-Cloud's current key or racer's earlier
    `metrics/EvaluationMetrics-<ts>.json`."""
    model = tmp_path / "out" / "alpha"
    (model / "metrics" / "evaluation").mkdir(parents=True)
    lap = {"elapsed_time_in_milliseconds": 0}
    (model / "metrics" / "EvaluationMetrics-20250101000000.json").write_text(json.dumps({"metrics": [lap]}))
    assert sequential_laps(tmp_path / "out", "alpha") == [0]
    newer = [{**lap, "elapsed_time_in_milliseconds": ms} for ms in (11200, 10900)]
    (model / "metrics" / "evaluation" / "evaluation-20260101000000.json").write_text(json.dumps({"metrics": newer}))
    (model / "metrics" / "TrainingMetrics.json").write_text(json.dumps({"metrics": []}))
    assert sequential_laps(tmp_path / "out", "alpha") == [11200, 10900]
