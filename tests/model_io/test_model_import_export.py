"""`import` with the console's checkpoint logic, `export` to the import-ready layout + car bundle, and the CLI."""

from __future__ import annotations

import io
import json
import tarfile
import time

import pytest
from click.testing import CliRunner

from racer.cli import main
from racer.model_io import (
    ArchiveDestination,
    FolderDestination,
    FolderSource,
    ModelExistsError,
    ProblemCode,
    StoreDestination,
    StoreSource,
    export_model,
    import_model,
    validate_location,
    validate_model,
)
from racer.shared.store import LocalStore, S3Store
from tests.model_io.model_io_builders import deepracer_model, pack, real_files, tiny_onnx, write

pytestmark = pytest.mark.usefixtures("deepracer_data")  # the builders read ../shared/deepracer-data

CKPT_PARTS = ("data-00000-of-00001", "index", "meta")


def checkpoint_keys(prefix: str, *names: str) -> set[str]:
    return {f"{prefix}/model/{name}.{part}" for name in names for part in CKPT_PARTS}


@pytest.fixture
def store(tmp_path) -> LocalStore:
    return LocalStore(tmp_path / "store")


def test_import_with_only_coach_checkpoint_copies_the_named_and_the_previous(tmp_path, store):
    source = deepracer_model(
        tmp_path / "m", checkpoints=("1_Step-42.ckpt", "2_Step-91.ckpt", "3_Step-124.ckpt", "4_Step-162.ckpt")
    )
    result = import_model(FolderSource(source), store, "console-model")
    assert result.ok, (result.report.problems, result.problems)
    expected = checkpoint_keys("console-model", "3_Step-124.ckpt", "4_Step-162.ckpt") | {
        "console-model/model/model_3.pb",
        "console-model/model/model_4.pb",
        "console-model/model/.coach_checkpoint",
        "console-model/model/model_metadata.json",
        "console-model/ip/hyperparameters.json",
        "console-model/reward_function.py",
        "console-model/training_params.yaml",
        "console-model/metrics/TrainingMetrics.json",
    }
    assert set(store.list_keys("console-model/")) == expected
    assert store.get_bytes("console-model/model/.coach_checkpoint") == b"4_Step-162.ckpt"
    index = "model/4_Step-162.ckpt.index"
    assert store.get_bytes(f"console-model/{index}") == (source / index).read_bytes()
    assert store.get_bytes("console-model/reward_function.py") == real_files().reward_function
    # The pointer is written last: nothing after it.
    assert result.written[-1] == "model/.coach_checkpoint"


def test_an_imported_tensorflow_checkpoint_cannot_be_run_and_says_why(tmp_path, store):
    from racer.shared.policy.checkpoints import CheckpointStore
    from racer.shared.policy.manifest import CheckpointError

    source = deepracer_model(tmp_path / "m")  # the console's layout: .coach_checkpoint names 4_Step-162.ckpt
    assert import_model(FolderSource(source), store, "console-model").ok
    checkpoints = CheckpointStore(store, "console-model")
    with pytest.raises(CheckpointError, match=r"console-model/model/4_Step-162\.ckpt is a TensorFlow checkpoint"):
        checkpoints.load_inference_policy()  # what racer evaluate does first


def test_import_with_deepracer_checkpoints_copies_best_and_last_only(tmp_path, store):
    names = ("2_Step-91.ckpt", "3_Step-124.ckpt", "4_Step-162.ckpt", "5_Step-200.ckpt")
    source = deepracer_model(
        tmp_path / "m", checkpoints=names, coach="5_Step-200.ckpt", best="3_Step-124.ckpt", last="5_Step-200.ckpt"
    )
    result = import_model(FolderSource(source), store, "best-and-last")
    assert result.ok
    copied = {key for key in store.list_keys("best-and-last/model/") if ".ckpt." in key}
    assert copied == checkpoint_keys("best-and-last", "3_Step-124.ckpt", "5_Step-200.ckpt")
    assert (
        store.get_bytes("best-and-last/model/deepracer_checkpoints.json")
        == (source / "model/deepracer_checkpoints.json").read_bytes()
    )
    assert store.get_bytes("best-and-last/model/.coach_checkpoint") == b"5_Step-200.ckpt"
    again = validate_model(StoreSource(store, "best-and-last"))
    assert again.ok and again.plan.selection.checkpoints == ("3_Step-124.ckpt", "5_Step-200.ckpt")


def test_import_from_a_tar_gz_with_metadata_at_the_root(tmp_path, store):
    source = deepracer_model(tmp_path / "m", metadata_at_root=True)
    (source / "ip/hyperparameters.json").rename(source / "hyperparameters.json")
    report, opened = validate_location(str(pack(source, tmp_path / "droa-export.tar.gz", wrapper="droa")))
    assert report.ok
    result = import_model(opened, store, "from-droa")
    assert result.ok
    # Stored in the trainer's layout whatever the source used.
    assert store.get_bytes("from-droa/model/model_metadata.json") == real_files().model_metadata
    assert store.get_bytes("from-droa/ip/hyperparameters.json") == real_files().hyperparameters


def test_an_invalid_model_is_not_imported(tmp_path, store):
    source = deepracer_model(tmp_path / "m")
    (source / "model/.coach_checkpoint").unlink()
    result = import_model(FolderSource(source), store, "broken")
    assert not result.ok
    assert result.report.codes == [ProblemCode.COACH_CHECKPOINT_DOES_NOT_EXIST]
    assert store.list_keys("broken/") == []


def test_import_refuses_to_overwrite_unless_asked(tmp_path, store):
    first = deepracer_model(tmp_path / "a", checkpoints=("1_Step-10.ckpt", "2_Step-20.ckpt"), coach="2_Step-20.ckpt")
    second = deepracer_model(tmp_path / "b")
    assert import_model(FolderSource(first), store, "same-name").ok
    with pytest.raises(ModelExistsError, match="same-name"):
        import_model(FolderSource(second), store, "same-name")
    assert import_model(FolderSource(second), store, "same-name", overwrite=True).ok
    # No file of the first model survives the overwrite.
    assert not any("2_Step-20" in key for key in store.list_keys("same-name/"))


@pytest.mark.parametrize("name", ["", "has space", "slash/inside", "x" * 65, "-leading-hyphen"])
def test_model_names_follow_the_console_rule(tmp_path, store, name):
    with pytest.raises(ValueError, match="model name"):
        import_model(FolderSource(deepracer_model(tmp_path / "m")), store, name)


# --- export ---------------------------------------------------------------------------------------------------------


def read_bundle(data: bytes) -> dict[str, bytes]:
    with tarfile.open(fileobj=io.BytesIO(data), mode="r:gz") as bundle:
        return {member.name: bundle.extractfile(member).read() for member in bundle.getmembers() if member.isfile()}


def test_export_writes_the_import_ready_layout_and_a_car_bundle(tmp_path, store):
    source = deepracer_model(tmp_path / "m")
    onnx_bytes = tiny_onnx(14)
    write(source, "model/model_4.onnx", onnx_bytes)
    assert import_model(FolderSource(source), store, "racer-model").ok
    dest = tmp_path / "export"
    result = export_model(store, "racer-model", FolderDestination(dest))
    assert result.ok, (result.problems, result.check)
    for key in (
        "ip/hyperparameters.json",
        "model/.coach_checkpoint",
        "model/deepracer_checkpoints.json",
        "model/model_metadata.json",
        "model_metadata.json",
        "hyperparameters.json",
        "reward_function.py",
        "training_params.yaml",
        "metrics/TrainingMetrics.json",
        "model/4_Step-162.ckpt.index",
        "model/model_4.onnx",
        "model.tar.gz",
    ):
        assert (dest / key).is_file(), key
    bundle = read_bundle((dest / "model.tar.gz").read_bytes())
    assert bundle == {"model_metadata.json": real_files().model_metadata, "agent/model.onnx": onnx_bytes}
    assert result.car_bundle_model == "agent/model.onnx"
    # validate accepts what export wrote (also checked inside export_model), as a folder and as a tar.gz.
    assert result.check.ok
    assert validate_location(str(dest))[0].ok
    assert validate_location(str(pack(dest, tmp_path / "export.tar.gz")))[0].ok
    # deepracer_checkpoints.json is written even though the import source had only .coach_checkpoint
    # (a missing one made the console say "checkpoint does not exist", DRfC #45).
    pointers = json.loads((dest / "model/deepracer_checkpoints.json").read_bytes())
    assert pointers["best_checkpoint"]["name"] == pointers["last_checkpoint"]["name"] == "4_Step-162.ckpt"


def test_export_of_a_tensorflow_model_bundles_the_frozen_graph(tmp_path, store):
    source = deepracer_model(tmp_path / "m", best="3_Step-124.ckpt", last="4_Step-162.ckpt")
    assert import_model(FolderSource(source), store, "tf-model").ok
    result = export_model(store, "tf-model", FolderDestination(tmp_path / "export"))
    assert result.ok
    bundle = read_bundle((tmp_path / "export" / "model.tar.gz").read_bytes())
    # The best checkpoint's graph, at DeepRacer's own path.
    assert bundle["agent/model.pb"] == (source / "model/model_3.pb").read_bytes()


def test_export_is_reproducible(tmp_path, store):
    source = deepracer_model(tmp_path / "m")
    write(source, "model/model_4.onnx", tiny_onnx(14))
    assert import_model(FolderSource(source), store, "m").ok
    export_model(store, "m", FolderDestination(tmp_path / "one"))
    time.sleep(1.1)  # gzip headers carry a time stamp in seconds unless it is pinned
    export_model(store, "m", FolderDestination(tmp_path / "two"))
    assert (tmp_path / "one/model.tar.gz").read_bytes() == (tmp_path / "two/model.tar.gz").read_bytes()


def test_export_to_a_tar_gz_that_validates_and_imports(tmp_path, store):
    source = deepracer_model(tmp_path / "m", best="3_Step-124.ckpt", last="4_Step-162.ckpt")
    write(source, "model/model_3.onnx", tiny_onnx(14))
    assert import_model(FolderSource(source), store, "m").ok
    archive = tmp_path / "virtualmodel-m.tar.gz"
    result = export_model(store, "m", ArchiveDestination(archive))
    assert result.ok, (result.problems, result.check)
    report, opened = validate_location(str(archive))
    assert report.ok and report.plan.selection.checkpoints == ("3_Step-124.ckpt", "4_Step-162.ckpt")
    with tarfile.open(archive) as outer:
        inner = outer.extractfile("model.tar.gz").read()
    assert read_bundle(inner)["agent/model.onnx"] == (source / "model/model_3.onnx").read_bytes()
    assert import_model(opened, store, "m-from-archive").ok


def test_a_failed_export_leaves_no_archive(tmp_path, store):
    assert import_model(FolderSource(deepracer_model(tmp_path / "m")), store, "m").ok
    store.delete("m/model/4_Step-162.ckpt.index")
    archive = tmp_path / "broken.tar.gz"
    result = export_model(store, "m", ArchiveDestination(archive))
    assert result.report.codes == [ProblemCode.CHECKPOINT_FILES_DOES_NOT_EXIST]
    assert not archive.exists()


def test_export_of_an_incomplete_stored_model_reports_its_problems(tmp_path, store):
    assert import_model(FolderSource(deepracer_model(tmp_path / "m")), store, "m").ok
    store.delete("m/reward_function.py")
    result = export_model(store, "m", FolderDestination(tmp_path / "export"))
    assert result.report.codes == [ProblemCode.FILE_DOES_NOT_EXIST]
    assert not (tmp_path / "export").exists()


def test_export_to_a_bucket_then_import_back(tmp_path, store, s3_settings):
    source = deepracer_model(tmp_path / "m")
    write(source, "model/model_4.onnx", tiny_onnx(14))
    assert import_model(FolderSource(source), store, "m").ok
    bucket = S3Store(s3_settings)
    result = export_model(store, "m", StoreDestination(bucket, "exports/m"))
    assert result.ok, (result.problems, result.check)
    assert bucket.exists("exports/m/model.tar.gz")
    back = LocalStore(tmp_path / "other-store")
    assert import_model(StoreSource(bucket, "exports/m"), back, "m-again").ok
    reimported = back.list_keys("m-again/")
    # Without deepracer_checkpoints.json in the store, export sends the pointer's checkpoint as best and last.
    assert {key for key in reimported if ".ckpt." in key} == checkpoint_keys("m-again", "4_Step-162.ckpt")
    for key in reimported:
        if not key.endswith("deepracer_checkpoints.json"):  # the only file export creates rather than copies
            assert back.get_bytes(key) == store.get_bytes("m/" + key.removeprefix("m-again/")), key


# --- command line ---------------------------------------------------------------------------------------------------


@pytest.mark.slow
def test_cli_validate_import_export(tmp_path):
    runner = CliRunner()
    source = deepracer_model(tmp_path / "m")
    store_dir = str(tmp_path / "store")

    broken = deepracer_model(tmp_path / "broken")
    (broken / "model/.coach_checkpoint").unlink()
    (broken / "reward_function.py").unlink()
    result = runner.invoke(main, ["model", "validate", str(broken)])
    assert result.exit_code == 1
    lines = [line for line in result.output.splitlines() if not line.startswith(" ")]
    assert sorted(line.split()[0] for line in lines[:2]) == ["COACH_CHECKPOINT_DOES_NOT_EXIST", "FILE_DOES_NOT_EXIST"]
    assert result.output.count("    fix: ") == 2

    result = runner.invoke(main, ["model", "validate", "--json", str(broken)])
    assert result.exit_code == 1
    assert {problem["code"] for problem in json.loads(result.output)["problems"]} == {
        "COACH_CHECKPOINT_DOES_NOT_EXIST",
        "FILE_DOES_NOT_EXIST",
    }

    result = runner.invoke(main, ["model", "import", str(broken), "nope", "--store", store_dir])
    assert result.exit_code == 1 and "COACH_CHECKPOINT_DOES_NOT_EXIST" in result.output

    result = runner.invoke(main, ["model", "import", str(source), "my-model", "--store", store_dir])
    assert result.exit_code == 0, result.output
    result = runner.invoke(main, ["model", "import", str(source), "my-model", "--store", store_dir])
    assert result.exit_code == 1 and "--overwrite" in result.output

    dest = tmp_path / "exported"
    result = runner.invoke(main, ["model", "export", "my-model", str(dest), "--store", store_dir])
    assert result.exit_code == 0, result.output
    result = runner.invoke(main, ["model", "validate", str(dest)])
    assert result.exit_code == 0 and result.output.startswith("OK"), result.output
    result = runner.invoke(main, ["model", "export", "my-model", str(dest), "--store", store_dir])
    assert result.exit_code == 1 and "not an empty folder" in result.output


def test_cli_store_defaults_to_racer_store(tmp_path):
    source = deepracer_model(tmp_path / "m")
    store_dir = tmp_path / "env-store"
    result = CliRunner().invoke(
        main, ["model", "import", str(source), "env-model"], env={"RACER_STORE": str(store_dir)}
    )
    assert result.exit_code == 0, result.output
    assert (store_dir / "env-model/model/.coach_checkpoint").read_bytes() == b"4_Step-162.ckpt"
