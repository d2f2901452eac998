"""A run checks its custom files once: `racer trainer` alone (compose) runs the preflight before it connects and hands
the report to the trainer; `racer train` runs it before any process starts and tells its trainer
(`--preflight-passed`), which then only reads the files. Counted on the real command paths, against a real Redis."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

import racer.trainer.preflight as preflight_module
import racer.trainer.run_files as run_files
from racer.local.run import LocalRunPlan, check_before_start, trainer_argv
from racer.shared.config import LocalStoreSettings, ServiceSettings
from racer.shared.deepracer.training_params import parse_training_params
from racer.shared.model_layout import ModelLayout
from racer.shared.run_settings import RunOptions
from racer.shared.store import open_store
from racer.trainer.cli import trainer_command
from tests.conftest import write_custom_files

pytestmark = pytest.mark.slow


@pytest.fixture
def counted_preflight(monkeypatch) -> list[tuple]:
    """Every call of the real preflight, with its arguments."""
    calls: list[tuple] = []
    real = preflight_module.preflight

    def counting(*args, **kwargs):
        calls.append((args, kwargs))
        return real(*args, **kwargs)

    monkeypatch.setattr(preflight_module, "preflight", counting)
    monkeypatch.setattr(run_files, "preflight", counting)  # the name the trainer's run files imported
    return calls


def run_trainer_cli(argv: list[str], redis_settings, store_root: Path) -> None:
    env = {"RACER_REDIS_URL": redis_settings.url, "RACER_STORE": str(store_root)}
    result = CliRunner().invoke(trainer_command, argv, env=env, catch_exceptions=False)
    assert result.exit_code == 0, result.output
    prefix = argv[argv.index("--model-prefix") + 1]
    assert open_store(LocalStoreSettings(store_root)).exists(ModelLayout(prefix).finished)


def plan_for(tmp_path: Path, custom_files: Path) -> LocalRunPlan:
    return LocalRunPlan(
        model_prefix="once",
        custom_files=custom_files,
        run=RunOptions(
            num_workers=2,
            track="racer_oval",
            worlds=("base", "wood"),
            car_profile="simtrace-fit",
            challenge_params=(("RACE_TYPE", "OBJECT_AVOIDANCE"), ("NUMBER_OF_OBSTACLES", "2")),
        ),
        max_episodes=None,
        max_minutes=0.0001,  # the trainer sets the run up (uploads, checkpoint 0), then stops
        use_minio=False,
        log_dir=tmp_path / "logs",
    )


def test_racer_train_checks_the_custom_files_once_and_its_trainer_reads_the_same_settings(
    tmp_path, redis_settings, counted_preflight
):
    custom_files = write_custom_files(tmp_path / "custom_files")
    plan = plan_for(tmp_path, custom_files)
    store_root = tmp_path / "store"
    check_before_start(plan, ServiceSettings(redis_settings, LocalStoreSettings(store_root)))
    assert len(counted_preflight) == 1
    (_folder, run), _ = counted_preflight[0]
    assert run == plan.run and run.car_profile == "simtrace-fit"

    argv = trainer_argv(plan)
    assert argv[0] == "trainer" and "--preflight-passed" in argv
    run_trainer_cli(argv[1:], redis_settings, store_root)
    assert len(counted_preflight) == 1  # the trainer process did not check again

    text = open_store(LocalStoreSettings(store_root)).get_bytes(ModelLayout("once").training_params(0)).decode()
    params = parse_training_params(text).values
    assert (params["RACER_CAR_PROFILE"], params["RACE_TYPE"], params["NUM_WORKERS"]) == (
        "simtrace-fit",
        "OBJECT_AVOIDANCE",
        "2",
    )


def test_racer_trainer_alone_checks_the_custom_files_once(tmp_path, redis_settings, counted_preflight):
    custom_files = write_custom_files(tmp_path / "custom_files")
    argv = [a for a in trainer_argv(plan_for(tmp_path, custom_files)) if a != "--preflight-passed"]
    run_trainer_cli(argv[1:], redis_settings, tmp_path / "store")
    assert len(counted_preflight) == 1
