"""A run's best lap against the lap-time bound: the racing line of the car that drove it (its worker's
training_params, or its evaluation's evaluation_params) on its track, from a LineBook (the viewer's own, or one shared by
all the runs `racer compare` compares)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from racer.analysis.run_line import LineBook, ratio_to_bound, run_car
from racer.shared.deepracer.training_params import TrainingParamsError, parse_training_params
from racer.shared.sim.tracks.track import Track, TrackError
from racer.shared.store import ObjectNotFoundError

if TYPE_CHECKING:
    from racer.viewer.run_reader import RunReader


def _params_of_lap(reader: RunReader, best: dict) -> tuple[str, dict] | str:
    """(file, keys) of the settings the best lap was driven with, or why they are not known."""
    if best.get("phase") == "evaluation":
        key = reader.key(best["run"], "evaluation_params.yaml")
        try:
            text = reader.store.get_bytes(key).decode("utf-8-sig")
            return key, dict(parse_training_params(text, key).values)
        except ObjectNotFoundError:
            return f"no {key}"
        except (TrainingParamsError, UnicodeDecodeError) as error:
            return str(error)
    params = reader.worker_params()
    worker = int(best.get("worker") or 0)
    chosen = params.get(worker, params.get(0))
    if chosen is None:
        return "no training_params.yaml"
    return f"{reader.prefix} worker {worker} training_params", chosen


def best_lap_bound(reader: RunReader, best: dict | None, lines: LineBook) -> dict:
    """{line_lap_s, ratio, line} for a complete best lap, or {note} saying why there is no ratio."""
    if not best or not best.get("complete"):
        return {"note": "no complete lap"}
    found = _params_of_lap(reader, best)
    if isinstance(found, str):
        return {"note": f"car not known: {found}"}
    source, params = found
    try:
        track = Track.load(str(params.get("WORLD_NAME", "")))
    except (TrackError, OSError) as error:
        return {"note": f"track not known: {error}"}
    car = run_car(params, source, track)
    if isinstance(car, str):
        return {"note": car}
    line = lines.line(car)
    if isinstance(line, str):
        return {"note": line}
    return {
        "line_lap_s": round(line.lap_time_s, 3),
        "ratio": ratio_to_bound(best["lap_time_s"], line),
        "line": car.describe(),
    }
