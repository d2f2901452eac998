"""Which track a run drove: the WORLD_NAME of each worker's params yaml, or --track; the analysis track and the
training workers that drove it."""

from __future__ import annotations

import re
import sys
from pathlib import Path

import yaml

from racer.analysis.sources import EVALUATION, SimtraceFiles
from racer.analysis.track_sections import Track, TrackError, load_track


def run_tracks(files: SimtraceFiles) -> dict[int | str, str]:
    """WORLD_NAME by who used it: worker i (training_params.yaml = worker 0, training_params_<i>.yaml = worker i)
    or "evaluation" (eval_params*.yaml, evaluation_params*.yaml)."""
    tracks: dict[int | str, str] = {}
    for name, data in sorted(files.params_yaml.items()):
        try:
            params = yaml.safe_load(data)
        except yaml.YAMLError as error:
            print(f"warning: {name}: not readable yaml ({error}); ignored", file=sys.stderr)
            continue
        world = params.get("WORLD_NAME") if isinstance(params, dict) else None
        if not world:
            continue
        filename = Path(name).name
        worker = re.match(r"training_params(?:_(\d+))?\.ya?ml$", filename)
        role = (int(worker.group(1) or 0)) if worker else EVALUATION
        tracks.setdefault(role, str(world))
    return tracks


def resolve_track(
    files: SimtraceFiles, track_arg: str | None, tracks_dir: Path | None, notes: list[str]
) -> tuple[Track | None, set[int] | None]:
    """(track, training workers that drove it; None = all).

    --track wins and is used for every worker. Otherwise the run's own WORLD_NAME (worker 0's first), if a route
    of that name is in the tracks folder; workers that trained on another track are left out of the pictures.
    """
    tracks = run_tracks(files)
    by_worker = {role: name for role, name in tracks.items() if isinstance(role, int)}
    several = len(set(by_worker.values())) > 1
    if track_arg:
        if several:
            notes.append(
                f"The workers trained on several tracks ({_listing(by_worker)}); all are drawn on {track_arg}."
            )
        return load_track(track_arg, tracks_dir), None  # an explicit track that cannot be loaded is an error
    if not tracks:
        notes.append(
            "No track given (--track NAME|PATH.npy) and none named by the run: tables only, no track pictures."
        )
        return None, None
    world = by_worker[min(by_worker)] if by_worker else tracks[EVALUATION]
    try:
        track = load_track(world, tracks_dir)
    except TrackError:
        notes.append(
            f"The run was on track {world!r}, which is not in the tracks folder; give its route with "
            "--track PATH.npy (or --tracks-dir): tables only, no track pictures."
        )
        return None, None
    notes.append(f"Track {world!r} taken from the run's params yaml.")
    if not several:
        return track, None
    others = {worker: name for worker, name in by_worker.items() if name != world}
    notes.append(
        f"Workers on other tracks ({_listing(others)}) are left out of the track pictures and the reward "
        "what-if; analyse them with --track."
    )
    return track, {worker for worker, name in by_worker.items() if name == world}


def _listing(by_worker: dict[int, str]) -> str:
    return ", ".join(f"worker {worker}: {name}" for worker, name in sorted(by_worker.items()))
