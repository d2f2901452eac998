"""Where a race's videos go: `videos/<entrant>-<view>.mp4` in the race's folder, beside the board that links them."""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import Any


def move_videos(local: Path, layout: Any, task: dict[str, Any], name: str) -> dict[str, str]:
    """The evaluation's videos moved into the race's videos folder as `<name>-<view>.mp4`: {view: file name}."""
    from racer.evaluation_worker.video import VIEWS

    videos_dir = Path(task["videos_dir"])
    videos_dir.mkdir(parents=True, exist_ok=True)
    videos = {}
    for view in VIEWS:
        path = local / layout.video(view)
        if path.is_file():
            target = videos_dir / f"{name}-{view}.mp4"
            shutil.move(path, target)
            videos[view] = target.name
    return videos
