"""The viewer's web app (Starlette): one page, a few JSON endpoints, the frames as JPEG and the run's files.

| route | what |
|---|---|
| `/` | the page (static/index.html; it polls the endpoints below) |
| `/static/...` | the page's script, style and the vendored Chart.js |
| `/api/run` | model, store, live or not, the workers' worlds, the track map |
| `/api/live` | workers (up/down, state, newest frame's pose, trail and JPEG), Redis reachable; renews `watching` (`watch=0`: no frames; `workers=0,2`: frames of these workers only) |
| `/api/progress` | per-iteration curves, evaluations per checkpoint, best lap path, `racer evaluate` runs |
| `/api/runs` | every run in the store: finished or not, iterations, last scores and progress (racer.viewer.store_runs) |
| `/api/runs/curves?run=<prefix>` | one listed run's per-iteration curves, to lay over the shown run's; 404 for anything else |
| `/api/workers/<id>/frame.jpg` | the newest camera frame of a worker |
| `/files/<key>` | a file of the run (videos, simtraces, metrics) from the store; nothing outside the model prefix; HTTP Range (206, 416) on a local and an S3 store |
"""

from __future__ import annotations

import hashlib
import time
from pathlib import Path

from starlette.applications import Starlette
from starlette.exceptions import HTTPException
from starlette.requests import Request
from starlette.responses import FileResponse, JSONResponse, Response
from starlette.routing import Mount, Route
from starlette.staticfiles import StaticFiles

from racer.shared.deepracer.metrics import MetricsError
from racer.shared.store import LocalStore, ObjectNotFoundError, S3Store
from racer.shared.store.base import validate_key
from racer.viewer.live import LiveRun
from racer.viewer.object_ranges import s3_object_response
from racer.viewer.run_reader import RunReader
from racer.viewer.store_runs import StoreRuns

STATIC_DIR = Path(__file__).resolve().parent / "static"

HEARTBEAT_STALE_S = 10.0
"""Workers beat every 3 s: a beat older than this means the worker is gone even if its key has not expired."""

FILE_TYPES = {
    ".mp4": "video/mp4",
    ".json": "application/json",
    ".jsonl": "application/json",
    ".csv": "text/csv",
    ".png": "image/png",
    ".yaml": "text/plain",
    ".py": "text/plain",
    ".html": "text/html",
    ".mcap": "application/octet-stream",
}
"""What /files serves (by suffix) and as which type; everything else under the prefix is 404."""


def _no_store(response: Response) -> Response:
    response.headers["Cache-Control"] = "no-store"
    return response


def _worker_ids(listed: str | None) -> list[int] | None:
    """`workers=0,2` (the panels on screen; empty: none) as ids; absent: None (all workers)."""
    if listed is None:
        return None
    try:
        return [int(part) for part in listed.split(",") if part.strip()]
    except ValueError:
        raise HTTPException(400, f"workers={listed!r}: expected worker ids separated by commas") from None


def create_app(files: RunReader, live: LiveRun | None) -> Starlette:
    runs = StoreRuns(files.store, files)

    async def index(request: Request) -> Response:
        return _no_store(FileResponse(STATIC_DIR / "index.html", media_type="text/html"))

    def run_info(request: Request) -> Response:
        return _no_store(
            JSONResponse(
                {
                    "model": files.prefix,
                    "store": files.store.describe(),
                    "live": live is not None,
                    "workers": files.workers(),
                    "track": files.track(),
                }
            )
        )

    def live_status(request: Request) -> Response:
        if live is None:
            return _no_store(JSONResponse({"live": False}))
        known = files.workers()
        watching = request.query_params.get("watch", "1") == "1"
        watched_ids = _worker_ids(request.query_params.get("workers"))
        snapshot = live.snapshot([w["id"] for w in known], watching=watching, watched_ids=watched_ids)
        worlds = {w["id"]: w["world"] for w in known}
        now = time.time()
        workers = []
        for worker_id in sorted(set(worlds) | set(snapshot.workers) | set(snapshot.frames)):
            beat = snapshot.workers.get(worker_id)
            age_s = None if beat is None else max(0.0, now - float(beat.get("time", now)))
            frame = snapshot.frames.get(worker_id)
            on_screen = watching and (watched_ids is None or worker_id in watched_ids)
            workers.append(
                {
                    "id": worker_id,
                    "world": (beat or {}).get("world") or worlds.get(worker_id, "?"),
                    "up": beat is not None and age_s <= HEARTBEAT_STALE_S,
                    "state": (beat or {}).get("state"),
                    "iteration": (beat or {}).get("iteration"),
                    "episodes": (beat or {}).get("episodes"),
                    "steps_per_s": (beat or {}).get("steps_per_s"),
                    "pid": (beat or {}).get("pid"),
                    "heartbeat_age_s": None if age_s is None else round(age_s, 1),
                    "frame": None if frame is None else LiveRun.frame_summary(frame, with_jpeg=on_screen),
                }
            )
        return _no_store(
            JSONResponse(
                {
                    "live": True,
                    "redis": {"ok": snapshot.redis_error is None, "error": snapshot.redis_error},
                    "workers": workers,
                }
            )
        )

    def progress(request: Request) -> Response:
        """With an ETag: a page that has the newest version gets a 304 and parses nothing (the curves of a long
        run are a large document, polled every 3 s)."""
        response = JSONResponse(files.progress())
        etag = f'"{hashlib.sha1(response.body).hexdigest()}"'
        if request.headers.get("if-none-match") == etag:
            response = Response(status_code=304)
        response.headers["ETag"] = etag
        return _no_store(response)

    def store_runs(request: Request) -> Response:
        return _no_store(JSONResponse({"runs": runs.summaries()}))

    def run_curves(request: Request) -> Response:
        prefix = request.query_params.get("run", "")
        try:
            iterations = runs.curves(prefix)
        except MetricsError as error:
            raise HTTPException(422, str(error)) from None
        if iterations is None:
            raise HTTPException(404, f"no run {prefix!r} in {files.store.describe()}")
        return _no_store(JSONResponse({"run": prefix, "iterations": iterations}))

    def frame_jpeg(request: Request) -> Response:
        worker_id = request.path_params["worker_id"]
        frame = live.frame(worker_id) if live is not None else None
        if frame is None or not frame.jpeg:
            raise HTTPException(404, f"no camera frame of worker {worker_id}")
        response = Response(frame.jpeg, media_type="image/jpeg")
        response.headers["X-Frame-Id"] = frame.frame_id
        return _no_store(response)

    def run_file(request: Request) -> Response:
        relative = request.path_params["path"]
        try:
            validate_key(relative)
        except ValueError:
            raise HTTPException(404, "no such file") from None
        media_type = FILE_TYPES.get(Path(relative).suffix.lower())
        if media_type is None:
            raise HTTPException(404, "no such file")
        key = files.key(relative)
        if isinstance(files.store, LocalStore):
            path = (files.store.root / key).resolve()
            run_root = (files.store.root / files.prefix).resolve()
            if not path.is_relative_to(run_root) or not path.is_file():
                raise HTTPException(404, "no such file")
            return FileResponse(path, media_type=media_type)  # Range requests: videos can seek
        if isinstance(files.store, S3Store):  # Range from S3 itself: videos seek in the compose deployment
            return s3_object_response(files.store, key, media_type, request.headers.get("range"))
        try:
            data = files.store.get_bytes(key)
        except ObjectNotFoundError:
            raise HTTPException(404, "no such file") from None
        return Response(data, media_type=media_type)

    routes = [
        Route("/", index),
        Route("/api/run", run_info),
        Route("/api/live", live_status),
        Route("/api/progress", progress),
        Route("/api/runs", store_runs),
        Route("/api/runs/curves", run_curves),
        Route("/api/workers/{worker_id:int}/frame.jpg", frame_jpeg),
        Route("/files/{path:path}", run_file),
        Mount("/static", StaticFiles(directory=STATIC_DIR), name="static"),
    ]
    return Starlette(routes=routes)
