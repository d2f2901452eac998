"""`racer compare` end to end on two short real runs, on a DeepRacer-for-Cloud run from MinIO, and its refusals."""

from __future__ import annotations

import base64
import io
import json
import re
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from PIL import Image

from racer.compare.cli import compare_command
from racer.shared.store import S3Store
from tests.short_runs import BASELINE, CENTRE
from tests.viewer.conftest import DRFC_MODEL, write_drfc_run

pytestmark = [pytest.mark.slow, pytest.mark.heavy]  # two real training runs (tests/conftest.py's two_short_runs)


def compare(*args: str, env: dict | None = None):
    # --no-line: the short runs' track is a big one, whose racing line takes minutes (tests/analysis test the ratio)
    result = CliRunner().invoke(compare_command, [*map(str, args), "--no-line"], env=env)
    assert result.exit_code == 0, result.output
    return result


def page_data(page: str) -> dict:
    match = re.search(r"<script type='application/json' id='compare-data'>(.*?)</script>", page, re.S)
    return json.loads(match.group(1).replace("<\\/", "</"))


def pictures(page: str) -> list[Image.Image]:
    found = []
    for encoded in re.findall(r"src='data:image/png;base64,([^']+)'", page):
        image = Image.open(io.BytesIO(base64.b64decode(encoded)))
        image.load()
        found.append(image)
    return found


def assert_drawn(image: Image.Image) -> None:
    """A real picture: large enough, many colours, not nearly all white (a blank or failed plot)."""
    assert image.width >= 600 and image.height >= 300, image.size
    pixels = np.asarray(image.convert("RGB")).reshape(-1, 3)
    assert len(np.unique(pixels[:: max(1, len(pixels) // 100_000)], axis=0)) > 30
    assert np.all(pixels == [255, 255, 255], axis=1).mean() < 0.97


def iterations_log(model: Path) -> list[dict]:
    return [json.loads(line) for line in (model / "metrics" / "iterations.jsonl").read_text().splitlines()]


def test_two_real_runs_side_by_side(two_short_runs, tmp_path):
    baseline, centre = two_short_runs
    out = tmp_path / "page.html"
    result = compare(baseline, centre, "--out", out)
    assert f"page: {out}" in result.output
    page = out.read_text()
    data = page_data(page)
    runs = {run["label"]: run for run in data["runs"]}
    assert list(runs) == [BASELINE, CENTRE]

    # The curves are the runs' own iteration logs, with the wall time of training from the trainer's clock.
    for label, model in ((BASELINE, baseline), (CENTRE, centre)):
        logged = iterations_log(model)
        shown = runs[label]["iterations"]
        assert [r["iteration"] for r in shown] == [r["iteration"] for r in logged]
        assert [r["mean_reward"] for r in shown] == [r["mean_reward"] for r in logged]
        assert [r["training_minutes"] for r in shown] == pytest.approx([r["elapsed_s"] / 60 for r in logged])
        # Each checkpoint's evaluation: as many trials as worker 0's evaluation entries in TrainingMetrics.json.
        metrics = json.loads((model / "metrics" / "TrainingMetrics.json").read_text())["metrics"]
        evaluated = [m for m in metrics if m["phase"] == "evaluation"]
        assert sum(e["trials"] for e in runs[label]["evaluations"]) == len(evaluated) > 0
        assert runs[label]["finished"] is True
    assert len(runs[BASELINE]["iterations"]) == 2 and len(runs[CENTRE]["iterations"]) == 3

    # The settings: what the second run changed is marked, what both share is not.
    settings = {label: run["settings"] for label, run in runs.items()}
    differing = {name for name in settings[BASELINE] if settings[BASELINE][name] != settings[CENTRE].get(name)}
    assert {"hyperparameters.json: num_epochs", "reward_function.py", "stop: max episodes"} <= differing
    assert settings[CENTRE]["hyperparameters.json: num_epochs"] == "5"
    assert "training_params.yaml: WORLD_NAME" not in differing
    assert not any("SAGEMAKER_SHARED_S3_PREFIX" in name for name in settings[BASELINE])  # always differs: left out
    marked = re.findall(r"<tr class='differs'><td>([^<]+)</td>", page)
    assert sorted(marked) == sorted(differing)
    assert "Stay near the centre line." in page  # the reward functions' code

    shown_pictures = pictures(page)
    assert len(shown_pictures) == 3  # training curves, evaluations, best laps
    for image in shown_pictures:
        assert_drawn(image)


def test_a_deepracer_for_cloud_run_in_minio_beside_a_racer_run(two_short_runs, s3_settings, deepracer_data, tmp_path):
    """DRfC's real sample run, read from a bucket by s3:// URL: curves from its TrainingMetrics.json, no wall time."""
    folder = write_drfc_run(tmp_path / "drfc-store", deepracer_data)
    store = S3Store(s3_settings)
    for path in folder.rglob("*"):
        if path.is_file() and not path.is_symlink():
            store.put_bytes(f"{DRFC_MODEL}/{path.relative_to(folder).as_posix()}", path.read_bytes())
    env = {
        "S3_ENDPOINT_URL": s3_settings.endpoint_url,
        "AWS_ACCESS_KEY_ID": s3_settings.access_key_id,
        "AWS_SECRET_ACCESS_KEY": s3_settings.secret_access_key,
    }
    out = tmp_path / "drfc.html"
    compare(f"s3://{s3_settings.bucket}/{DRFC_MODEL}", two_short_runs[0], "--out", out, env=env)
    data = page_data(out.read_text())
    drfc, racer_run = data["runs"]
    metrics = json.loads((deepracer_data / "metrics" / "drfc1_TrainingMetrics.json").read_text())["metrics"]
    training = [m for m in metrics if m["phase"] == "training"]
    starts = sum(1 for index, m in enumerate(training) if m["trial"] == 1 or index == 0)
    assert len(drfc["iterations"]) == starts > 10
    assert all(r["training_minutes"] is None for r in drfc["iterations"])
    assert drfc["best_lap"]["complete"] is True and drfc["source"].startswith(f"{DRFC_MODEL} in s3://")
    assert drfc["settings"]["model_metadata.json: action_space"].startswith("14 actions:")
    assert racer_run["label"] == BASELINE
    assert len(pictures(out.read_text())) == 3


def test_refusals_name_what_is_wrong(two_short_runs, tmp_path):
    result = CliRunner().invoke(compare_command, [str(two_short_runs[0])])
    assert result.exit_code == 2 and "at least two runs" in result.output
    missing = tmp_path / "no-such-run"
    result = CliRunner().invoke(
        compare_command, [str(two_short_runs[0]), str(missing)], env={"RACER_STORE": str(tmp_path)}
    )
    assert result.exit_code == 1 and "no-such-run" in result.output and "no model folder" in result.output
