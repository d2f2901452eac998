"""`validate` on local folders and archives: one broken model per console code, each giving exactly that code."""

from __future__ import annotations

import io
import json
import tarfile
from pathlib import Path

import pytest

from racer.model_io import ProblemCode, SizeLimits, validate_location
from tests.model_io.model_io_builders import (
    BROKEN,
    deepracer_model,
    edit_metadata_speed,
    pack,
    remove,
    seed_coach_example,
    tf_checkpoint,
    tiny_onnx,
    write,
)

pytestmark = pytest.mark.usefixtures("deepracer_data")  # the builders read ../shared/deepracer-data

Code = ProblemCode


@pytest.fixture
def model_dir(tmp_path) -> Path:
    return deepracer_model(tmp_path / "model-prefix")


def test_the_valid_model_passes_with_the_console_checkpoint_logic(model_dir):
    report, _ = validate_location(str(model_dir))
    assert report.problems == ()
    assert report.plan is not None
    # .coach_checkpoint names 4_Step-162.ckpt: the console copies it and the one before it.
    assert report.plan.selection.checkpoints == ("3_Step-124.ckpt", "4_Step-162.ckpt")
    assert report.plan.selection.source == "model/.coach_checkpoint"
    assert "model/model_4.pb" in report.plan.checkpoint_files
    assert "metrics/TrainingMetrics.json" in report.plan.optional_keys


def test_a_valid_onnx_inference_model_passes(model_dir):
    write(model_dir, "model/model_4.onnx", tiny_onnx(14))
    report, _ = validate_location(str(model_dir))
    assert report.ok, report.problems
    assert "model/model_4.onnx" in report.plan.checkpoint_files


@pytest.mark.parametrize("case", sorted(BROKEN))
def test_each_broken_model_gives_exactly_its_code(model_dir, case):
    breakage, expected = BROKEN[case]
    breakage(model_dir)
    report, _ = validate_location(str(model_dir))
    assert report.codes == [expected], [problem.render() for problem in report.problems]
    assert report.plan is None
    problem = report.problems[0]
    assert problem.fix and problem.message


def test_problems_name_the_file_and_the_field(model_dir):
    edit_metadata_speed(model_dir)
    report, _ = validate_location(str(model_dir))
    (problem,) = report.problems
    assert problem.path == "model/model_metadata.json"
    assert "action_space[3].speed" in problem.message and "7.0" in problem.message


def test_every_problem_is_reported_not_just_the_first(model_dir):
    remove("reward_function.py")(model_dir)
    remove("model/.coach_checkpoint")(model_dir)
    edit_metadata_speed(model_dir)
    report, _ = validate_location(str(model_dir))
    assert sorted(report.codes) == sorted(
        [Code.FILE_DOES_NOT_EXIST, Code.COACH_CHECKPOINT_DOES_NOT_EXIST, Code.MODEL_VALIDATION_SERVICE_ERROR]
    )


def test_deepracer_checkpoints_json_takes_precedence_over_coach_checkpoint(model_dir):
    # The pointer names a checkpoint that does not exist, but the json is consulted first and is fine.
    tf_checkpoint(model_dir, "5_Step-200.ckpt")
    write(model_dir, "model/.coach_checkpoint", "99_Step-99999.ckpt")
    write(
        model_dir,
        "model/deepracer_checkpoints.json",
        json.dumps({"best_checkpoint": {"name": "3_Step-124.ckpt"}, "last_checkpoint": {"name": "5_Step-200.ckpt"}}),
    )
    report, _ = validate_location(str(model_dir))
    assert report.ok, report.problems
    assert report.plan.selection.checkpoints == ("3_Step-124.ckpt", "5_Step-200.ckpt")
    assert (report.plan.selection.best, report.plan.selection.pointer) == ("3_Step-124.ckpt", "5_Step-200.ckpt")
    assert any("ignored" in note for note in report.notes)


def test_coach_checkpoint_picks_the_previous_complete_checkpoint(tmp_path):
    """Seed: pointer 4_Step-162.ckpt among 1..4 -> copy 3_Step-124 and 4_Step-162; a partial 3 is skipped."""
    root = deepracer_model(
        tmp_path / "m", checkpoints=("1_Step-42.ckpt", "2_Step-91.ckpt", "3_Step-124.ckpt", "4_Step-162.ckpt")
    )
    report, _ = validate_location(str(root))
    assert report.plan.selection.checkpoints == ("3_Step-124.ckpt", "4_Step-162.ckpt")
    (root / "model/3_Step-124.ckpt.index").unlink()
    report, _ = validate_location(str(root))
    assert report.plan.selection.checkpoints == ("2_Step-91.ckpt", "4_Step-162.ckpt")


def test_the_first_checkpoint_alone_is_importable(tmp_path):
    root = deepracer_model(tmp_path / "m", checkpoints=("0_Step-0.ckpt",), coach="0_Step-0.ckpt")
    report, _ = validate_location(str(root))
    assert report.ok and report.plan.selection.checkpoints == ("0_Step-0.ckpt",)


def test_metadata_and_hyperparameters_at_the_prefix_root_are_accepted(tmp_path):
    """DeepRacer-on-AWS exports keep model_metadata.json and hyperparameters.json at the root."""
    root = deepracer_model(tmp_path / "m", metadata_at_root=True)
    (root / "ip/hyperparameters.json").rename(root / "hyperparameters.json")
    report, _ = validate_location(str(root))
    assert report.ok, report.problems
    assert (report.plan.metadata_key, report.plan.hyperparameters_key) == (
        "model_metadata.json",
        "hyperparameters.json",
    )


def test_nothing_there(tmp_path):
    (tmp_path / "empty").mkdir()
    for location in (tmp_path / "empty", tmp_path / "missing"):
        report, _ = validate_location(str(location))
        assert report.codes == [Code.FILE_DOES_NOT_EXIST]


# --- archives ---------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("wrapper", [None, "my-model"])
def test_a_tar_gz_of_a_valid_model_passes(model_dir, tmp_path, wrapper):
    archive = pack(model_dir, tmp_path / "model.tar.gz", wrapper)
    report, _ = validate_location(str(archive))
    assert report.ok, report.problems
    assert report.plan.selection.checkpoints == ("3_Step-124.ckpt", "4_Step-162.ckpt")


def test_a_tar_gz_of_a_broken_model_reports_the_same_codes(model_dir, tmp_path):
    seed_coach_example(model_dir)
    report, _ = validate_location(str(pack(model_dir, tmp_path / "model.tar.gz")))
    assert report.codes == [Code.CHECKPOINT_FILES_DOES_NOT_EXIST]


def test_an_archive_that_is_not_a_tar_is_an_edited_model(tmp_path):
    write(tmp_path, "model.tar.gz", b"\x1f\x8b this is not gzip data")
    report, _ = validate_location(str(tmp_path / "model.tar.gz"))
    assert report.codes == [Code.MODEL_VALIDATION_SERVICE_ERROR]


def test_an_archive_with_an_unsafe_member_path_is_refused(tmp_path):
    archive = tmp_path / "evil.tar.gz"
    with tarfile.open(archive, "w:gz") as tar:
        info = tarfile.TarInfo("../outside.txt")
        info.size = 2
        tar.addfile(info, io.BytesIO(b"hi"))
    report, _ = validate_location(str(archive))
    assert report.codes == [Code.MODEL_VALIDATION_SERVICE_ERROR]
    assert "unsafe path" in report.problems[0].message


# --- size limits ------------------------------------------------------------------------------------------------


def test_model_archive_over_the_limit(model_dir, tmp_path):
    archive = pack(model_dir, tmp_path / "model.tar.gz")
    size = archive.stat().st_size
    report, _ = validate_location(str(archive), SizeLimits(model_bytes=size - 1))
    assert report.codes == [Code.MODEL_TAR_FILE_SIZE_LIMIT_EXCEEDED]
    report, _ = validate_location(str(archive), SizeLimits(model_bytes=size * 100))
    assert report.ok


def test_archive_that_unpacks_over_the_limit(model_dir, tmp_path):
    write(model_dir, "model/4_Step-162.ckpt.data-00000-of-00001", bytes(200_000))  # compresses to almost nothing
    archive = pack(model_dir, tmp_path / "model.tar.gz")
    report, _ = validate_location(str(archive), SizeLimits(model_bytes=archive.stat().st_size + 1000))
    assert report.codes == [Code.MODEL_TAR_FILE_SIZE_LIMIT_EXCEEDED]
    assert "unpacked" in report.problems[0].message


def test_files_to_copy_over_the_model_limit(model_dir):
    report, _ = validate_location(str(model_dir))
    total = report.plan.total_bytes
    report, _ = validate_location(str(model_dir), SizeLimits(model_bytes=total - 1))
    assert report.codes == [Code.MODEL_TAR_FILE_SIZE_LIMIT_EXCEEDED]


def test_checkpoint_file_over_the_limit(model_dir):
    write(model_dir, "model/4_Step-162.ckpt.data-00000-of-00001", bytes(5000))
    report, _ = validate_location(str(model_dir), SizeLimits(checkpoint_file_bytes=4999))
    assert report.codes == [Code.CHECKPOINT_FILE_SIZE_LIMIT_EXCEEDED]
    assert report.problems[0].path == "model/4_Step-162.ckpt.data-00000-of-00001"


def test_json_file_over_the_limit(model_dir):
    others = max(path.stat().st_size for path in model_dir.rglob("*") if path.suffix in {".json", ".yaml"})
    document = json.loads((model_dir / "ip/hyperparameters.json").read_bytes())
    write(model_dir, "ip/hyperparameters.json", json.dumps(document) + " " * (others + 10))
    report, _ = validate_location(str(model_dir), SizeLimits(json_yaml_bytes=others + 1))
    assert report.codes == [Code.JSON_YAML_FILE_SIZE_LIMIT_EXCEEDED]
    assert report.problems[0].path == "ip/hyperparameters.json"


def test_default_limits_on_real_sized_files(model_dir):
    """The documented defaults (10 MiB JSON/YAML, 512 MiB per checkpoint file, 1 GiB model) with files of those
    sizes; the big ones are sparse, so the test writes almost nothing."""
    write(model_dir, "metrics/TrainingMetrics.json", b" " * ((10 << 20) + 1))
    with open(model_dir / "model/4_Step-162.ckpt.data-00000-of-00001", "r+b") as handle:
        handle.truncate((512 << 20) + 1)
    with open(model_dir / "model.tar.gz", "wb") as handle:
        handle.truncate((1 << 30) + 1)
    report, _ = validate_location(str(model_dir))
    assert sorted(report.codes) == sorted(
        [
            Code.JSON_YAML_FILE_SIZE_LIMIT_EXCEEDED,
            Code.CHECKPOINT_FILE_SIZE_LIMIT_EXCEEDED,
            Code.MODEL_TAR_FILE_SIZE_LIMIT_EXCEEDED,
        ]
    )


def test_an_old_tensorflow_pointer_is_pointed_out(model_dir):
    remove("model/.coach_checkpoint")(model_dir)
    write(model_dir, "model/checkpoint", 'model_checkpoint_path: "4_Step-162.ckpt"\n')
    report, _ = validate_location(str(model_dir))
    assert report.codes == [Code.COACH_CHECKPOINT_DOES_NOT_EXIST]
    assert "model/checkpoint" in report.problems[0].fix and "4_Step-162.ckpt" in report.problems[0].fix


def test_per_worker_training_params_are_checked_and_copied(model_dir):
    write(model_dir, "training_params_1.yaml", "WORLD_NAME: reinvent_base\n")
    report, _ = validate_location(str(model_dir))
    assert "training_params_1.yaml" in report.plan.optional_keys
    write(model_dir, "training_params_1.yaml", "- just\n- a list\n")
    report, _ = validate_location(str(model_dir))
    assert report.codes == [Code.MODEL_VALIDATION_SERVICE_ERROR] and report.problems[0].path == "training_params_1.yaml"
