"""`python -m benchmarks transfer --matrix --randomization` picks the cells it trains, and `--keep-models` keeps each model."""

from __future__ import annotations

import json

from click.testing import CliRunner

from benchmarks import transfer_matrix
from benchmarks.transfer import transfer_bench_command


def test_randomization_on_trains_only_the_randomised_cell_and_keeps_its_model(tmp_path, monkeypatch, deepracer_data):
    trained = []

    def train_cell(cell, workdir, custom, track, minutes, workers, seed, worlds):
        """Stands in for a training run: a model folder with one file, no iteration records."""
        assert worlds == ("base",)  # the reverse-check setup unless --train-world says otherwise
        trained.append(cell.model_prefix)
        (workdir / "store" / cell.model_prefix).mkdir(parents=True)
        (workdir / "store" / cell.model_prefix / "marker").write_text(cell.model_prefix)
        return workdir / "store", []

    monkeypatch.setattr(transfer_matrix, "train_cell", train_cell)
    monkeypatch.setattr(transfer_matrix, "drive_last_checkpoint", lambda *args: (None, {}))
    kept = tmp_path / "kept"
    args = ["--matrix", "--train-profile", "gazebo", "--train-profile", "simapp6-ros2", "--randomization", "on"]
    args += ["--data", str(deepracer_data)]
    result = CliRunner().invoke(transfer_bench_command, [*args, "--keep-models", str(kept)], catch_exceptions=False)
    assert result.exit_code == 0, result.output
    assert trained == ["matrix-simapp6-gazebo-dr", "matrix-simapp6-simapp6-ros2-dr"]
    report = json.loads(result.stdout.strip().splitlines()[-1])
    assert [run["dynamics_randomization"] for run in report["runs"]] == [True, True]
    assert [run["generation"] for run in report["runs"]] == ["simapp6", "simapp6"]
    assert (kept / "matrix-simapp6-simapp6-ros2-dr" / "marker").read_text() == "matrix-simapp6-simapp6-ros2-dr"

    trained.clear()
    result = CliRunner().invoke(
        transfer_bench_command,
        ["--matrix", "--train-profile", "gazebo", "--randomization", "off", "--data", str(deepracer_data)],
    )
    assert result.exit_code == 0 and trained == ["matrix-simapp6-gazebo-fixed"]


def test_the_matrix_trains_per_generation_and_drives_in_every_generation(monkeypatch, deepracer_data):
    """By default a model trained in a generation (its own car) is driven in each generation with its own car; the
    drives' env configs carry the generation and its car."""
    from racer.shared.sim.generations.catalog import GENERATION_NAMES, generation

    cells, configs = [], []
    monkeypatch.setattr(
        transfer_matrix, "train_cell", lambda cell, workdir, *rest: (cells.append(cell), (workdir / "store", []))[1]
    )

    def drive_last_checkpoint(store_root, cell, track, cars, starts, drive):
        configs.extend(car.env_config(track, None) for car in cars)
        return None, {car.label: {"laps": 0, "starts": starts, "mean_progress": 0.0} for car in cars}

    monkeypatch.setattr(transfer_matrix, "drive_last_checkpoint", drive_last_checkpoint)
    args = ["--matrix", "--train-generation", "2019", "--randomization", "on", "--data", str(deepracer_data)]
    result = CliRunner().invoke(transfer_bench_command, args, catch_exceptions=False)
    assert result.exit_code == 0, result.output
    assert [(cell.generation, cell.profile, cell.model_prefix) for cell in cells] == [("2019", "", "matrix-2019-dr")]
    assert [(config.generation, config.car_dynamics) for config in configs] == [
        (name, generation(name).car) for name in GENERATION_NAMES
    ]
    report = json.loads(result.stdout.strip().splitlines()[-1])
    assert list(report["matrix"]["matrix-2019-dr"]) == list(GENERATION_NAMES)


def test_train_world_spreads_the_matrix_workers_over_the_worlds_given(tmp_path, monkeypatch, deepracer_data):
    """`--train-world` reaches the training run's options (worker i on the i-th world, cycling, as `racer train`),
    and the report says which worlds trained."""
    import racer.local.run
    from racer.shared.run_settings import load_worker_settings

    plans, worker_worlds = [], []

    def run_local_training(plan, base):
        plans.append(plan)
        worker_worlds.append([worker.world for worker in load_worker_settings(plan.custom_files, plan.run)])

    monkeypatch.setattr(racer.local.run, "run_local_training", run_local_training)
    monkeypatch.setattr(transfer_matrix, "read_iteration_records", lambda store_root, plan: [])
    monkeypatch.setattr(transfer_matrix, "drive_last_checkpoint", lambda *args: (None, {}))
    args = ["--matrix", "--randomization", "on", "--train-world", "base", "--train-world", "carpet"]
    args += ["--workers", "3", "--data", str(deepracer_data)]
    result = CliRunner().invoke(transfer_bench_command, args, catch_exceptions=False)
    assert result.exit_code == 0, result.output
    assert [plan.run.worlds for plan in plans] == [("base", "carpet")]
    assert worker_worlds == [["base", "carpet", "base"]]
    report = json.loads(result.stdout.strip().splitlines()[-1])
    assert report["train_worlds"] == ["base", "carpet"]
