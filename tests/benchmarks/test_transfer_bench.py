"""`python -m benchmarks transfer` imports the real DeepRacer checkpoints through `racer model import`'s path and drives them
in racer closed loop; `--racer-model` compares a racer model's steering with theirs on DeepRacer's Gazebo frames."""

from __future__ import annotations

import json

import pytest
import torch
from click.testing import CliRunner

from benchmarks.transfer import transfer_bench_command
from racer.shared.deepracer.model_metadata import parse_model_metadata
from racer.shared.policy.checkpoints import CheckpointStore
from racer.shared.policy.networks import build_actor_critic
from racer.shared.store import LocalStore
from tests.shared_data import SHARED_DATA

pytestmark = pytest.mark.slow

SAMPLE = SHARED_DATA / "models" / "gazebo-sample-reinvent2018"


def _racer_model(store_root):
    """A fresh (untrained) racer model with the sample's 12 actions, in racer's local store layout."""
    metadata = parse_model_metadata(json.loads((SAMPLE / "model_metadata.json").read_text()))
    torch.manual_seed(0)
    checkpoints = CheckpointStore(LocalStore(store_root), "fresh")
    checkpoints.put_model_metadata(metadata)
    checkpoints.save(0, 0, build_actor_critic(metadata), model_metadata=metadata)
    return store_root / "fresh"


def test_two_starts_of_each_real_checkpoint_and_the_reverse_check(tmp_path, deepracer_data):
    racer_model = _racer_model(tmp_path)
    args = ["--starts", "2", "--racer-model", str(racer_model), "--data", str(deepracer_data)]
    result = CliRunner().invoke(transfer_bench_command, args, catch_exceptions=False)
    assert result.exit_code == 0, result.output
    report = json.loads([line for line in result.stdout.splitlines() if line.startswith("{")][-1])
    drives = {drive["model"]: drive for drive in report["drives"]}
    assert sorted(drives) == ["gazebo-sample-reinvent2018/15_Step-0.ckpt", "gazebo-sample-reinvent2018/30_Step-0.ckpt"]
    for drive in drives.values():
        assert drive["starts"] == 2 and len(drive["progress_per_start"]) == 2
        assert 0 < drive["mean_progress"] <= 100  # it drove somewhere before leaving the track or finishing
        assert drive["laps"] == sum(p >= 100 for p in drive["progress_per_start"])
    reverse = report["reverse_check"]["checkpoints"]["0_Step-0.ckpt"]
    assert sum(reverse["shares"].values()) == pytest.approx(1.0, abs=0.002)
    assert set(reverse["sign_agreement"]) == set(drives)
    assert all(0.0 <= value <= 1.0 for value in reverse["sign_agreement"].values())
    # the baseline: the same policies on racer's own frames of the lap
    on_racer = reverse["racer_frames"]
    assert sum(on_racer["shares"].values()) == pytest.approx(1.0, abs=0.002)
    assert set(on_racer["sign_agreement"]) == set(drives)
    assert set(report["reverse_check"]["real_shares_on_racer_frames"]) == set(drives)
    # the real run's own spread: its two checkpoints against each other, on both sets of frames
    spread = report["reverse_check"]["real_sign_agreement"]
    assert list(spread) == [" vs ".join(sorted(drives))]
    assert all(0.0 < value < 1.0 for value in spread[" vs ".join(sorted(drives))].values())


def test_each_car_profile_given_is_driven(monkeypatch, deepracer_data):
    """`--car-profile` repeats: every checkpoint drives in each profile given, and the line says which."""
    from benchmarks import transfer as transfer_bench
    from racer.shared.sim.car.dynamics import CAR_DYNAMICS

    driven = []

    def drive(model, config, starts):
        driven.append((model.label, config.car_dynamics))
        return {"laps": 0, "starts": starts, "mean_progress": 1.0, "progress_per_start": [1.0] * starts}

    monkeypatch.setattr(transfer_bench, "drive", drive)
    args = ["--starts", "1", "--car-profile", "gazebo", "--car-profile", "simtrace-fit", "--data", str(deepracer_data)]
    result = CliRunner().invoke(transfer_bench_command, args, catch_exceptions=False)
    assert result.exit_code == 0, result.output
    report = json.loads([line for line in result.stdout.splitlines() if line.startswith("{")][-1])
    assert [drive["car_profile"] for drive in report["drives"]] == ["gazebo", "simtrace-fit"] * 2
    assert [drive["generation"] for drive in report["drives"]] == ["2019"] * 4  # the landing rule's generation
    assert [dynamics for _, dynamics in driven] == [CAR_DYNAMICS["gazebo"], CAR_DYNAMICS["simtrace-fit"]] * 2
    bad = CliRunner().invoke(transfer_bench_command, ["--car-profile", "f1"])
    assert bad.exit_code == 2 and "'gazebo', 'simtrace-fit'" in bad.output


def test_each_generation_given_is_driven_with_its_own_look_and_car(monkeypatch, deepracer_data):
    """`--generation` repeats: without --car-profile every checkpoint drives each generation's car in its look."""
    from benchmarks import transfer as transfer_bench
    from racer.shared.sim.generations.catalog import generation

    driven = []

    def drive(model, config, starts):
        driven.append((config.generation, config.car_dynamics, config.look))
        return {"laps": 0, "starts": starts, "mean_progress": 1.0, "progress_per_start": [1.0] * starts}

    monkeypatch.setattr(transfer_bench, "drive", drive)
    args = ["--starts", "1", "--generation", "simapp6", "--generation", "2019", "--data", str(deepracer_data)]
    result = CliRunner().invoke(transfer_bench_command, args, catch_exceptions=False)
    assert result.exit_code == 0, result.output
    report = json.loads([line for line in result.stdout.splitlines() if line.startswith("{")][-1])
    names = ["simapp6", "2019"] * 2
    assert [(d["generation"], d["car_profile"]) for d in report["drives"]] == [
        (name, generation(name).car_profile) for name in names
    ]
    assert driven == [(name, generation(name).car, generation(name).look) for name in names]


def test_without_deepracer_data_the_bench_names_the_option_and_the_variable(monkeypatch):
    monkeypatch.delenv("RACER_DEEPRACER_DATA", raising=False)
    result = CliRunner().invoke(transfer_bench_command, ["--starts", "1"])
    assert result.exit_code == 2 and "--data" in result.output and "RACER_DEEPRACER_DATA" in result.output


def test_matrix_trains_each_cell_and_drives_its_last_checkpoint(deepracer_data):
    """`--matrix` with a tiny budget: one generation, with dynamics randomisation only (which cells `--randomization`
    picks is tested without training, test_transfer_matrix_cells.py), 0.3 minutes, one start."""
    args = ["--matrix", "--train-generation", "simapp6", "--generation", "simapp6", "--randomization", "on"]
    args += ["--minutes", "0.3", "--starts", "1", "--workers", "1", "--data", str(deepracer_data)]
    result = CliRunner().invoke(transfer_bench_command, args, catch_exceptions=False)
    assert result.exit_code == 0, result.output
    report = json.loads([line for line in result.stdout.splitlines() if line.startswith("{")][-1])
    assert report["benchmark"] == "transfer-matrix" and report["minutes_per_model"] == 0.3
    runs = {run["model"]: run for run in report["runs"]}
    assert sorted(runs) == ["matrix-simapp6-dr"]
    assert runs["matrix-simapp6-dr"]["dynamics_randomization"] is True
    for name, run in runs.items():
        assert (run["generation"], run["car_profile"]) == ("simapp6", "")
        if run["checkpoint"] is not None:  # a checkpoint within 18 s is likely, not certain on a loaded machine
            assert list(run["drives"]) == ["simapp6"] and run["drives"]["simapp6"]["starts"] == 1
            assert report["matrix"][name]["simapp6"].startswith(f"{run['drives']['simapp6']['laps']}/1 ")
