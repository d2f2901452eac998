"""The viewer's endpoints over real HTTP (uvicorn on loopback): content types, 404s, no way out of the model folder,
a real DeepRacer-for-Cloud run opened from the store alone, and the live endpoints on a real redis-server."""

from __future__ import annotations

import base64
import http.client
import json
import os
import subprocess
import sys
import time
import urllib.error
import urllib.request

import cv2
import numpy as np
import pytest

from racer.analysis.aggregate import episodes
from racer.analysis.loading import load_steps
from racer.analysis.sources import from_folder
from racer.shared.config import RedisSettings
from racer.shared.redis_connection import RedisLink
from racer.shared.store import LocalStore
from racer.shared.transport.channels import RunChannel
from racer.shared.transport.frames import FrameChannel
from racer.viewer.app import create_app
from racer.viewer.live import LiveRun
from racer.viewer.run_reader import RunLocation, RunNotFoundError, RunReader, resolve_run
from tests.viewer.conftest import DRFC_MODEL, EVALUATION_RUN, ServedApp, free_port
from tests.viewer.frames import publish_frame


def get(url: str, headers: dict | None = None) -> tuple[int, str, bytes]:
    request = urllib.request.Request(url, headers=headers or {})
    try:
        with urllib.request.urlopen(request, timeout=30) as response:
            return response.status, response.headers.get("Content-Type", ""), response.read()
    except urllib.error.HTTPError as error:
        return error.code, error.headers.get("Content-Type", ""), error.read()


def raw_get(port: int, path: str) -> int:
    """A request line sent as written (urllib and browsers would normalise `..` away)."""
    connection = http.client.HTTPConnection("127.0.0.1", port, timeout=30)
    connection.putrequest("GET", path, skip_host=False, skip_accept_encoding=True)
    connection.endheaders()
    status = connection.getresponse().status
    connection.close()
    return status


@pytest.fixture
def store_viewer(drfc_store):
    files = RunReader(resolve_run(str(drfc_store / DRFC_MODEL)))
    with ServedApp(create_app(files, live=None)) as served:
        yield served


def test_page_and_static_files_have_their_content_types(store_viewer):
    status, kind, body = get(store_viewer.url + "/")
    assert status == 200 and kind.startswith("text/html") and b"/static/viewer.js" in body
    for name, expected in [
        ("viewer.js", "javascript"),
        ("style.css", "text/css"),
        ("chart-4.6.1.umd.min.js", "javascript"),
    ]:
        status, kind, body = get(f"{store_viewer.url}/static/{name}")
        assert status == 200 and expected in kind and len(body) > 1000, name
    assert get(store_viewer.url + "/static/nothing.js")[0] == 404
    assert get(store_viewer.url + "/api/nothing")[0] == 404
    assert raw_get(store_viewer.port, "/static/../app.py") == 404


def test_a_deepracer_for_cloud_run_opens_from_the_store_alone(store_viewer, drfc_store):
    status, kind, body = get(store_viewer.url + "/api/run")
    run = json.loads(body)
    assert status == 200 and kind == "application/json"
    assert run["model"] == DRFC_MODEL and run["live"] is False
    assert [w["world"] for w in run["workers"]] == ["base"]
    track = run["track"]
    assert track["name"].endswith("reinvent_base.npy") and len(track["outer"]) == len(track["inner"]) > 50

    progress = json.loads(get(store_viewer.url + "/api/progress")[2])
    # Curves from TrainingMetrics.json (a DRfC run has no iterations.jsonl): one point per iteration.
    assert len(progress["iterations"]) >= 27
    assert progress["iterations"][-1]["mean_reward"] > progress["iterations"][0]["mean_reward"]
    assert progress["evaluations"] and all(e["trials"] >= 1 for e in progress["evaluations"])
    assert any(e["laps_completed"] > 0 for e in progress["evaluations"])

    # The best lap is the one racer analyze finds, with its path on the track.
    steps = load_steps(from_folder(drfc_store / DRFC_MODEL), progress=False)
    table = episodes(steps)
    expected = table.loc[table["lap_complete"], "lap_time_s"].min()
    best = progress["best_lap"]
    assert best["complete"] and best["lap_time_s"] == pytest.approx(expected, abs=1e-3)
    xs = [p[0] for p in best["path"]]
    ys = [p[1] for p in best["path"]]
    outer = np.array(track["outer"])
    assert len(best["path"]) > 50
    assert outer[:, 0].min() <= min(xs) and max(xs) <= outer[:, 0].max()
    assert outer[:, 1].min() <= min(ys) and max(ys) <= outer[:, 1].max()

    runs = progress["evaluation_runs"]
    assert [r["name"] for r in runs] == [EVALUATION_RUN]
    assert runs[0]["laps"][0]["lap_time_s"] == 12.5
    video_url = runs[0]["videos"][0]["url"]
    status, kind, body = get(store_viewer.url + video_url)
    assert status == 200 and kind == "video/mp4" and body[4:8] == b"ftyp"
    status, _kind, part = get(store_viewer.url + video_url, headers={"Range": "bytes=0-99"})
    assert status == 206 and part == body[:100]  # seeking in the video works


def test_files_never_leave_the_model_folder(store_viewer):
    url, port = store_viewer.url, store_viewer.port
    status, kind, body = get(f"{url}/files/{EVALUATION_RUN}/summary.json")
    assert status == 200 and kind == "application/json" and json.loads(body)["mode"] == "deepracer"
    status, kind, _ = get(f"{url}/files/training-simtrace/26-iteration.csv")
    assert status == 200 and kind.startswith("text/csv")
    assert get(f"{url}/files/metrics/none.json")[0] == 404
    assert get(f"{url}/files/model")[0] == 404  # a folder
    assert get(f"{url}/files/reward_function.pyc")[0] == 404  # a type it does not serve
    for path in [
        "/files/../secret.json",
        "/files/..%2Fsecret.json",
        "/files/%2E%2E/secret.json",
        f"/files/../{DRFC_MODEL}-other/x.json",
        "/files//etc/passwd",
        "/files/model/escape.json",
        "/files/model/..%2F..%2Fsecret.json",
    ]:
        assert raw_get(port, path) == 404, path


def test_view_refuses_what_is_not_a_run(tmp_path, monkeypatch):
    monkeypatch.setenv("RACER_STORE", str(tmp_path / "empty-store"))
    with pytest.raises(RunNotFoundError, match="no-such-model"):
        resolve_run("no-such-model")


@pytest.mark.serial  # asserts a wall-time bound
def test_live_endpoints_show_workers_frames_and_a_lost_redis(tmp_path, redis_server):
    store = LocalStore(tmp_path / "store")
    for key, world in [("training_params.yaml", "base"), ("training_params_1.yaml", "carpet")]:
        params = f"WORLD_NAME: racer_oval\nNUM_WORKERS: '2'\nRACER_WORLD: {world}\n"
        store.put_bytes(f"live-model/{key}", params.encode())
    settings = RedisSettings(url=redis_server.url, connect_timeout_s=5)
    link = RedisLink(settings)
    run, frames = RunChannel(link, "live-model"), FrameChannel(link, "live-model")
    app = create_app(RunReader(RunLocation(store, "live-model")), LiveRun(settings, "live-model"))
    with ServedApp(app) as served:
        info = json.loads(get(served.url + "/api/run")[2])
        assert info["live"] and [w["world"] for w in info["workers"]] == ["base", "carpet"]
        assert info["track"]["name"] == "racer_oval" and info["track"]["length_m"] > 10

        run.beat(
            1, {"state": "playing", "iteration": 3, "episodes": 7, "world": "carpet", "steps_per_s": 120.0, "pid": 4242}
        )
        publish_frame(frames, 1, seq=5, shade=200)
        assert not frames.is_watched()
        status, kind, body = get(served.url + "/api/live")
        live = json.loads(body)
        assert status == 200 and kind == "application/json" and live["redis"]["ok"]
        assert frames.is_watched()  # an open page makes the workers publish
        frames.clear_watching()
        status, _kind, body = get(served.url + "/api/live?watch=1&workers=1")  # only worker 1's panel on screen
        assert status == 200 and frames.is_watched(1) and not frames.is_watched(0)
        shown = {w["id"]: w for w in json.loads(body)["workers"]}[1]["frame"]
        jpeg = np.frombuffer(base64.b64decode(shown["jpeg_base64"]), np.uint8)  # the image comes with the poll
        assert int(cv2.imdecode(jpeg, cv2.IMREAD_GRAYSCALE).mean()) in range(195, 206)
        unwatched = json.loads(get(served.url + "/api/live?watch=0")[2])["workers"]
        assert "jpeg_base64" not in {w["id"]: w for w in unwatched}[1]["frame"]  # a hidden page gets no images
        frames.clear_watching()
        assert get(served.url + "/api/live?watch=0")[0] == 200 and not frames.is_watched(1)
        assert get(served.url + "/api/live?workers=1,x")[0] == 400
        by_id = {w["id"]: w for w in live["workers"]}
        assert by_id[0]["up"] is False and by_id[0]["frame"] is None  # no heartbeat: down
        assert by_id[1]["up"] and by_id[1]["state"] == "playing" and by_id[1]["pid"] == 4242
        assert by_id[1]["frame"]["id"] == "s1-5" and by_id[1]["frame"]["trail"] == [[1.0, -0.5], [1.5, -0.5]]

        status, kind, body = get(served.url + "/api/workers/1/frame.jpg")
        assert status == 200 and kind == "image/jpeg"
        assert int(cv2.imdecode(np.frombuffer(body, np.uint8), cv2.IMREAD_GRAYSCALE).mean()) in range(195, 206)
        assert get(served.url + "/api/workers/0/frame.jpg")[0] == 404
        assert get(served.url + "/api/workers/x/frame.jpg")[0] == 404

        redis_server.kill()
        started = time.monotonic()
        live = json.loads(get(served.url + "/api/live")[2])
        assert not live["redis"]["ok"] and live["redis"]["error"]
        assert time.monotonic() - started < 5  # the page is told at once, not after a long retry
        assert get(served.url + "/api/workers/1/frame.jpg")[0] == 404
        assert get(served.url + "/api/progress")[0] == 200  # curves come from the store: still there

        redis_server.start()
        deadline = time.monotonic() + 20
        while not (live := json.loads(get(served.url + "/api/live")[2]))["redis"]["ok"]:
            assert time.monotonic() < deadline, live
            time.sleep(0.3)
        run.beat(1, {"state": "playing", "world": "carpet"})
        live = json.loads(get(served.url + "/api/live")[2])
        assert {w["id"]: w["up"] for w in live["workers"]}[1]


def test_racer_view_serves_a_model_folder_and_refuses_anything_else(drfc_store, tmp_path):
    port = free_port()
    env = dict(os.environ, RACER_STORE=str(tmp_path / "elsewhere"))
    server = subprocess.Popen(
        [sys.executable, "-m", "racer.cli", "view", str(drfc_store / DRFC_MODEL), "--port", str(port)],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        env=env,
    )
    try:
        deadline = time.monotonic() + 60
        while True:
            try:
                status, _kind, body = get(f"http://127.0.0.1:{port}/api/run")
                break
            except urllib.error.URLError:
                assert server.poll() is None and time.monotonic() < deadline, server.stdout.read()
                time.sleep(0.3)
        assert status == 200 and json.loads(body)["model"] == DRFC_MODEL
    finally:
        server.terminate()
        output, _ = server.communicate(timeout=30)
    assert f"at http://localhost:{port}/" in output
    refused = subprocess.run(
        [sys.executable, "-m", "racer.cli", "view", "no-such-model"],
        capture_output=True,
        text=True,
        env=env,
        timeout=60,
    )
    assert refused.returncode != 0 and "no-such-model" in refused.stderr and "no model folder" in refused.stderr


def test_progress_is_sent_again_only_when_it_changed(tmp_path):
    store = LocalStore(tmp_path / "store")
    record = {"iteration": 0, "mean_reward": 1.0, "mean_progress": 5.0, "completion_rate": 0.0, "worlds": {}}
    store.put_bytes("etag-model/metrics/iterations.jsonl", (json.dumps(record) + "\n").encode())
    with ServedApp(create_app(RunReader(RunLocation(store, "etag-model")), None)) as served:
        with urllib.request.urlopen(served.url + "/api/progress", timeout=30) as response:
            etag = response.headers["ETag"]
            assert response.status == 200 and len(json.loads(response.read())["iterations"]) == 1 and etag
        status, _kind, body = get(served.url + "/api/progress", {"If-None-Match": etag})
        assert status == 304 and body == b""  # the page has it: nothing to send or parse
        store.put_bytes(
            "etag-model/metrics/iterations.jsonl",
            (json.dumps(record) + "\n" + json.dumps({**record, "iteration": 1}) + "\n").encode(),
        )
        status, _kind, body = get(served.url + "/api/progress", {"If-None-Match": etag})
        assert status == 200 and len(json.loads(body)["iterations"]) == 2
