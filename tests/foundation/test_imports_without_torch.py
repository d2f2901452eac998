"""The worker image's contract: the rollout worker, the evaluation worker, the live viewer and
`racer race` (the compose `race` profile) import no torch.

Their docker image (docker/Dockerfile, target `worker`) has no torch; the trainer's has. Each entry module is imported
in a fresh interpreter, with the module the command then runs (`racer rollout` builds a `RolloutWorker`, `racer
evaluate` an `EvaluationSession`, `racer view` the app), and `torch` must not be in `sys.modules` afterwards. A module
that needs torch again on that path fails here, before the worker image fails at run time.
(tests/policy/test_action_selection.py also acts with saved checkpoints in a process where torch cannot be imported.)
"""

from __future__ import annotations

import subprocess
import sys

import pytest

WORKER_PATHS = {
    "rollout": ["racer.cli", "racer.rollout_worker.cli", "racer.rollout_worker.worker"],
    "evaluation": ["racer.cli", "racer.evaluation_worker.cli", "racer.evaluation_worker.runner"],
    "viewer": ["racer.cli", "racer.viewer.cli", "racer.viewer.app", "racer.viewer.live"],
    "minio-setup": ["racer.shared.store"],
    "race": ["racer.cli", "racer.race.cli", "racer.race.runner", "racer.race.worker", "racer.race.html_report"],
}
TORCH_MODULES = ("torch", "safetensors.torch")

_PROBE = """
import importlib, json, sys
for name in sys.argv[1:]:
    importlib.import_module(name)
print(json.dumps(sorted(name for name in sys.modules if name in {torch_modules!r})))
"""


@pytest.mark.parametrize("role", sorted(WORKER_PATHS))
def test_the_worker_image_roles_import_no_torch(role):
    result = subprocess.run(
        [sys.executable, "-c", _PROBE.format(torch_modules=set(TORCH_MODULES)), *WORKER_PATHS[role]],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "[]", (
        f"importing {WORKER_PATHS[role]} imported {result.stdout.strip()}: the {role} runs in the image without torch "
        f"(find the importer with: python -X importtime -c 'import {WORKER_PATHS[role][-1]}' 2>&1 | grep -w torch)"
    )


def test_the_probe_sees_torch_when_a_module_imports_it():
    result = subprocess.run(
        [sys.executable, "-c", _PROBE.format(torch_modules=set(TORCH_MODULES)), "racer.shared.policy.networks"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 0, result.stderr
    assert "torch" in result.stdout


_LINE_WITHOUT_TORCH = """
import sys

class Refuse:
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] == "torch":
            raise ModuleNotFoundError("No module named 'torch'", name="torch")
        return None

sys.meta_path.insert(0, Refuse())
from racer.analysis.run_line import LineBook, run_car
from racer.shared.sim.tracks.track import Track

car = run_car({"WORLD_NAME": "racer_oval", "RACER_GENERATION": "simapp6"}, "params", Track.load("racer_oval"))
print(LineBook().line(car))
"""


def test_without_torch_a_racing_line_is_a_reason_not_a_crash():
    """`racer analyze` and the viewer run in the worker image: there the line comparison says why it is missing
    (the compose smoke test's analysis service once died of the ModuleNotFoundError)."""
    result = subprocess.run([sys.executable, "-c", _LINE_WITHOUT_TORCH], capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr[-3000:]
    assert "computing the racing line needs torch" in result.stdout, result.stdout
