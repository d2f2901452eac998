"""Where a race's videos go: `videos/<entrant>-<view>.mp4` in the race's folder, beside the board that links them."""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import Any

ALL_CARS_TOP_VIEW = "all-cars-topview.mp4"
"""HEAD_TO_MODEL / F1: every car on one top view (evaluation_worker/multi_car_video.py); never an entrant's
`<name>-camera-<view>.mp4`, so no entrant's name clashes with it."""


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


def race_videos(out_dir: Path, multi_car: bool) -> dict[str, str]:
    """The race's own videos (not one entrant's), by name in the videos folder: HEAD_TO_MODEL and F1 have the
    all-cars top view."""
    if multi_car and (out_dir / "videos" / ALL_CARS_TOP_VIEW).is_file():
        return {"allCarsTopView": ALL_CARS_TOP_VIEW}
    return {}
