"""A real DeepRacer-for-Cloud model folder in a temporary store, and the viewer served on a loopback port."""

from __future__ import annotations

import json
import socket
import threading
import time
from pathlib import Path

import imageio.v3 as iio
import numpy as np
import pytest
import uvicorn

from tests.browser import chromium

DRFC_MODEL = "drfc-model"
EVALUATION_RUN = "evaluation-20220709200242"


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def write_drfc_run(store_root: Path, deepracer_data: Path) -> Path:
    """DeepRacer-for-Cloud's sample run (simtraces, TrainingMetrics, its evaluation) laid out as DRfC writes it,
    plus what `racer evaluate` adds to an evaluation folder (summary.json, a video) and files the viewer must not
    serve: one outside the model prefix and one in a sibling folder whose name starts with the model's."""
    model = store_root / DRFC_MODEL
    simtrace = deepracer_data / "simtrace"
    for iteration in (0, 26):
        target = model / "training-simtrace" / f"{iteration}-iteration.csv"
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_bytes((simtrace / f"drfc1_training_{iteration}-iteration.csv").read_bytes())
    evaluation = model / EVALUATION_RUN
    (evaluation / "evaluation-simtrace").mkdir(parents=True)
    (evaluation / "evaluation-simtrace" / "0-iteration.csv").write_bytes(
        (simtrace / "drfc1_evaluation_0-iteration.csv").read_bytes()
    )
    (model / "metrics").mkdir()
    (model / "metrics" / "TrainingMetrics.json").write_bytes(
        (deepracer_data / "metrics" / "drfc1_TrainingMetrics.json").read_bytes()
    )
    route = deepracer_data / "routes" / "reinvent_base.npy"
    (model / "training_params.yaml").write_text(f"WORLD_NAME: {route}\nNUM_WORKERS: '1'\nRACER_WORLD: base\n")
    (model / "model").mkdir()
    (model / "model" / "model_metadata.json").write_bytes(
        (deepracer_data / "config" / "drfc1_model_metadata.json").read_bytes()
    )
    video = evaluation / "camera-topview" / "0-video.mp4"
    video.parent.mkdir()
    frames = np.zeros((8, 48, 64, 3), dtype=np.uint8)
    frames[:, :, :, 1] = np.linspace(0, 255, 8, dtype=np.uint8)[:, None, None]
    iio.imwrite(video, frames, fps=15, codec="libx264")
    (evaluation / "summary.json").write_text(
        json.dumps(
            {
                "mode": "deepracer",
                "checkpoint": "26_Step-52000.ckpt",
                "laps_completed": 1,
                "best_lap_time_s": 12.5,
                "laps": [
                    {
                        "lap": 1,
                        "label": "Lap complete",
                        "lap_time_s": 12.5,
                        "elapsed_s": 12.5,
                        "progress_pct": 100.0,
                        "put_backs": 0,
                    }
                ],
            }
        )
    )
    (store_root / "secret.json").write_text('{"secret": true}')
    (store_root / (DRFC_MODEL + "-other")).mkdir()
    (store_root / (DRFC_MODEL + "-other") / "x.json").write_text('{"other": true}')
    (model / "model" / "escape.json").symlink_to(store_root / "secret.json")
    return model


class ServedApp:
    """An ASGI app served by uvicorn in a thread of the test process, on a free loopback port."""

    def __init__(self, app):
        self.port = free_port()
        self.server = uvicorn.Server(uvicorn.Config(app, host="127.0.0.1", port=self.port, log_level="warning"))
        self.thread = threading.Thread(target=self.server.run, daemon=True)

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.port}"

    def __enter__(self) -> ServedApp:
        self.thread.start()
        deadline = time.monotonic() + 20
        while not self.server.started:
            if time.monotonic() > deadline or not self.thread.is_alive():
                raise RuntimeError("the viewer did not start")
            time.sleep(0.05)
        return self

    def __exit__(self, *exc) -> None:
        self.server.should_exit = True
        self.thread.join(10)


@pytest.fixture
def drfc_store(tmp_path, deepracer_data) -> Path:
    root = tmp_path / "store"
    write_drfc_run(root, deepracer_data)
    return root


@pytest.fixture
def browser():
    """A headless chromium (tests.browser) for the page tests."""
    yield from chromium()
