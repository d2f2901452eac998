"""`racer view RACE_FOLDER`: a finished race's leaderboard page in the browser, its videos playable.

leaderboard.html links its videos relatively (`videos/<entrant>-camera-incar.mp4`, `videos/all-cars-topview.mp4`) and
browsers will not play them from a `file://` page in every setting, nor seek without HTTP Range; so the folder is
served as it is: `/` is leaderboard.html, every other path a file of the folder of a type the board links (videos,
the board's JSON and CSV, pictures), with Range requests so videos seek. Nothing outside the folder, and nothing else
in it (task files, logs), is served.

| route | what |
|---|---|
| `/` | leaderboard.html |
| `/<path>` | a file in the race folder: .mp4, .json, .csv, .html, .png; 404 otherwise |
"""

from __future__ import annotations

from pathlib import Path

from starlette.applications import Starlette
from starlette.exceptions import HTTPException
from starlette.requests import Request
from starlette.responses import FileResponse, Response
from starlette.routing import Route

from racer.shared.store.base import validate_key

RACE_FILE_TYPES = {
    ".mp4": "video/mp4",
    ".json": "application/json",
    ".csv": "text/csv",
    ".html": "text/html",
    ".png": "image/png",
}
BOARD_PAGE = "leaderboard.html"
_NOT_SERVED = {"task.json", "result.json"}
"""The race's own bookkeeping (paths of this machine), not part of the board."""


class NotARaceFolderError(ValueError):
    """The folder holds no finished race (no leaderboard.html)."""


def is_race_folder(path: Path) -> bool:
    return path.is_dir() and (path / BOARD_PAGE).is_file() and (path / "leaderboard.json").is_file()


def create_race_app(folder: Path) -> Starlette:
    root = folder.resolve()
    if not is_race_folder(root):
        raise NotARaceFolderError(f"{folder}: no finished race here (no {BOARD_PAGE} and leaderboard.json)")

    async def board(request: Request) -> Response:
        response = FileResponse(root / BOARD_PAGE, media_type="text/html")
        response.headers["Cache-Control"] = "no-store"  # a race run again in the same folder rewrites it
        return response

    async def race_file(request: Request) -> Response:
        relative = request.path_params["path"]
        try:
            validate_key(relative)
        except ValueError:
            raise HTTPException(404, "no such file") from None
        media_type = RACE_FILE_TYPES.get(Path(relative).suffix.lower())
        path = (root / relative).resolve()
        if media_type is None or path.name in _NOT_SERVED or not path.is_relative_to(root) or not path.is_file():
            raise HTTPException(404, "no such file")
        return FileResponse(path, media_type=media_type)  # Range requests: videos seek

    return Starlette(routes=[Route("/", board), Route("/{path:path}", race_file)])
