"""The viewer's list of the runs in its store and another run's curves for an overlay, over real HTTP."""

from __future__ import annotations

import json
import urllib.error
import urllib.parse
import urllib.request

from racer.shared.store import LocalStore
from racer.viewer.app import create_app
from racer.viewer.run_reader import RunLocation, RunReader
from racer.viewer.store_runs import run_prefixes
from tests.viewer.conftest import DRFC_MODEL, ServedApp


def get_json(url: str) -> tuple[int, dict]:
    try:
        with urllib.request.urlopen(url, timeout=30) as response:
            return response.status, json.loads(response.read())
    except urllib.error.HTTPError as error:
        return error.code, {}


def record(iteration: int, reward: float) -> dict:
    return {
        "iteration": iteration,
        "episodes": 2,
        "mean_reward": reward,
        "mean_progress": 10.0 + iteration,
        "completion_rate": 0.0,
        "elapsed_s": 5.0 * (iteration + 1),
        "worlds": {},
    }


def test_run_prefixes_are_the_folders_with_a_runs_files():
    keys = [
        "a/metrics/iterations.jsonl",
        "a/model/model_metadata.json",
        "team/b/metrics/TrainingMetrics.json",
        "c/model/model_metadata.json",
        ".runs/a/metrics/iterations.jsonl",
        "d/reward_function.py",
        "metrics/iterations.jsonl",
    ]
    assert run_prefixes(keys) == ["a", "c", "team/b"]


def test_the_store_s_runs_and_their_curves(drfc_store):
    store = LocalStore(drfc_store)
    lines = [record(0, 4.0), record(1, 6.5), record(2, 9.0)]
    store.put_bytes("racer-run/metrics/iterations.jsonl", "".join(json.dumps(r) + "\n" for r in lines).encode())
    store.put_bytes("racer-run/model/.finished", b"")
    store.put_bytes(".runs/racer-run/metrics/iterations.jsonl", b"{}\n")  # racer train's logs: not a run
    with ServedApp(create_app(RunReader(RunLocation(store, DRFC_MODEL)), None)) as served:
        status, listed = get_json(served.url + "/api/runs")
        assert status == 200
        runs = {run["name"]: run for run in listed["runs"]}
        assert set(runs) == {DRFC_MODEL, "racer-run"}
        assert runs[DRFC_MODEL]["current"] and not runs["racer-run"]["current"]
        assert runs["racer-run"]["finished"] and not runs[DRFC_MODEL]["finished"]
        assert runs["racer-run"]["iterations"] == 3 and runs["racer-run"]["mean_reward"] == 9.0
        assert runs[DRFC_MODEL]["iterations"] > 10  # built from its TrainingMetrics.json

        status, curves = get_json(served.url + "/api/runs/curves?run=racer-run")
        assert status == 200 and [r["mean_reward"] for r in curves["iterations"]] == [4.0, 6.5, 9.0]
        assert curves["iterations"][2]["elapsed_s"] == 15.0
        for name in ("nothing", ".runs/racer-run", "racer-run/metrics", ""):
            status, _ = get_json(served.url + "/api/runs/curves?run=" + urllib.parse.quote(name))
            assert status == 404, name
