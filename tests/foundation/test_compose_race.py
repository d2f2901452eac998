"""The compose `race` profile: `racer race` in the worker image against MinIO, wired as the `evaluation` and
`analysis` profiles are, with its settings in .env.example (docs/evaluation.md, "A race in the compose deployment")."""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[2]


def _compose() -> dict:
    return yaml.safe_load((ROOT / "docker-compose.yml").read_text())


def test_race_service_runs_racer_race_on_the_store_with_the_races_folder_mounted():
    services = _compose()["services"]
    race, evaluation = services["race"], services["evaluation"]
    assert race["profiles"] == ["race"]
    assert race["image"] == evaluation["image"] and race["environment"]["RACER_STORE"].startswith("s3://")
    assert race["environment"]["S3_ENDPOINT_URL"] == evaluation["environment"]["S3_ENDPOINT_URL"]
    assert race["entrypoint"] == ["racer-as-owner", "/work/races", "racer"] and race["working_dir"] == "/work"
    assert race["command"].startswith("race races/${RACER_RACE_FILE:-race.yaml} ${RACER_RACE_ENTRANTS:-}")
    assert "${RACER_RACES:-./races}:/work/races" in race["volumes"]
    assert race["depends_on"] == {"minio-setup": {"condition": "service_completed_successfully"}}


def test_every_race_setting_is_in_env_example():
    text = (ROOT / "docker-compose.yml").read_text()
    block = text[text.index("\n  race:\n") : text.index("\n  # On demand: docker compose --profile analysis")]
    used = set(re.findall(r"\$\{(RACER_RACE\w*)", block))
    assert used == {"RACER_RACES", "RACER_RACE_FILE", "RACER_RACE_ENTRANTS", "RACER_RACE_ARGS"}
    example = (ROOT / ".env.example").read_text()
    for name in used:
        assert re.search(rf"^{name}=", example, re.MULTILINE), name


@pytest.mark.skipif(shutil.which("docker-compose") is None, reason="docker-compose is not installed")
def test_compose_parses_with_and_without_the_race_profile(tmp_path):
    env = {"RACER_S3_ACCESS_KEY": "racer-services", "RACER_S3_SECRET_KEY": "x" * 8}
    env |= {"MINIO_ROOT_USER": "root", "MINIO_ROOT_PASSWORD": "x" * 8, "PATH": "/usr/bin:/bin"}
    for profile in ([], ["--profile", "race"]):
        done = subprocess.run(
            ["docker-compose", "--project-directory", str(ROOT), "-f", str(ROOT / "docker-compose.yml"), *profile]
            + ["config", "--services"],
            capture_output=True,
            text=True,
            env=env,
            cwd=tmp_path,
            timeout=60,
        )
        assert done.returncode == 0, done.stderr
        assert "race" in done.stdout.split()  # (compose v1 lists the services of every profile)
