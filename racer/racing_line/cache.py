"""Computed lines kept in racer's cache (`line_cache()`: `lines/` beside the fetched routes), so asking again for the
same line costs a file read, not minutes of optimising.

A line depends on the route file, its direction, the car and the world (tyre grip differs by world), and on the
optimiser's settings: the key is the SHA-256 of all of them (`LineKey`). An entry is one `.npz` of plain arrays and a
JSON header (no pickle); one that cannot be read, or whose header does not match its key, is a miss, and the caller
computes the line again over it.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import tempfile
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from racer.racing_line.limits import CarLimits, LapTimeBoundError
from racer.racing_line.line import RacingLine, racing_line
from racer.racing_line.optimiser import (
    AUGMENTED_LAGRANGIAN,
    BORDER_MARGIN_M,
    CONTROL_SPACINGS_M,
    DEFAULT_SPACING_M,
    FTOL_S,
    MAX_ITERATIONS,
    SLSQP_MAX_SIZE,
    STEERING_PENALTY_S_M2,
    ProgressCallback,
)
from racer.shared.sim.car.dynamics import CarDynamics
from racer.shared.sim.tracks.simapp_routes import file_sha256
from racer.shared.sim.tracks.track import Track

CACHE_FORMAT = 3
"""Bumped whenever the model or the entry's layout changes what a key would give."""
OPTIMISER_SETTINGS = (
    f"SLSQP ftol {FTOL_S} maxiter {MAX_ITERATIONS} up to {SLSQP_MAX_SIZE} controls x rows, beyond it "
    f"{AUGMENTED_LAGRANGIAN}, steering penalty {STEERING_PENALTY_S_M2}, border margin {BORDER_MARGIN_M}, each "
    "stage's controls on the line before"
)
_ARRAYS = ("points_m", "speeds_mps", "curvatures_per_m")


def dynamics_sha256(dynamics: CarDynamics) -> str:
    """A stable hash of every field of the car's dynamics (nested dataclasses, as sorted JSON)."""
    return hashlib.sha256(json.dumps(dataclasses.asdict(dynamics), sort_keys=True).encode()).hexdigest()


@dataclass(frozen=True)
class LineKey:
    """Everything a line depends on."""

    route_sha256: str
    direction: str
    dynamics_sha256: str
    world: str
    limits: CarLimits
    """Derived from the car and the world, and from the car model's constants (mass, wheelbase, steering limit)."""
    spacing_m: float
    control_spacings_m: tuple[float, ...]
    optimiser: str = OPTIMISER_SETTINGS
    """The optimiser's other settings: a change to any of them makes a new key."""

    @property
    def digest(self) -> str:
        fields = {**dataclasses.asdict(self), "format": CACHE_FORMAT}
        return hashlib.sha256(json.dumps(fields, sort_keys=True).encode()).hexdigest()


@dataclass(frozen=True)
class CacheLookup:
    """A hit (`line`), a plain miss, or an entry that was there and could not be used (`problem` says why)."""

    line: RacingLine | None
    path: Path
    problem: str | None = None


def line_key(
    track: Track,
    dynamics: CarDynamics,
    limits: CarLimits,
    spacing_m: float = DEFAULT_SPACING_M,
    control_spacings_m: tuple[float, ...] = CONTROL_SPACINGS_M,
) -> LineKey:
    """The key of `track`'s line (its route file read for the hash) for the car with `dynamics` and `limits`."""
    source = Path(track.source)
    if not source.is_file():
        raise LapTimeBoundError(f"track {track.name}: no route file to key its cached line by ({track.source})")
    return LineKey(
        route_sha256=file_sha256(source),
        direction=direction_of(track),
        dynamics_sha256=dynamics_sha256(dynamics),
        world=limits.world,
        limits=limits,
        spacing_m=spacing_m,
        control_spacings_m=tuple(control_spacings_m),
    )


def direction_of(track: Track) -> str:
    """How the route runs: clockwise or counter-clockwise."""
    return "counter-clockwise" if track.is_ccw else "clockwise"


class LineCache:
    """The folder of cached lines."""

    def __init__(self, folder: Path) -> None:
        self.folder = Path(folder)

    def path(self, track: str, key: LineKey) -> Path:
        return self.folder / f"{track}-{key.digest[:24]}.npz"

    def load(self, track: str, key: LineKey) -> CacheLookup:
        path = self.path(track, key)
        if not path.is_file():
            return CacheLookup(None, path)
        try:
            with np.load(path, allow_pickle=False) as entry:
                header = json.loads(str(entry["header"]))
                arrays = {name: np.array(entry[name], dtype=np.float64) for name in _ARRAYS}
            line = _line_of(header, arrays, key)
        except (OSError, EOFError, ValueError, KeyError, TypeError, zipfile.BadZipFile) as error:
            return CacheLookup(None, path, f"{path}: unreadable cache entry ({type(error).__name__}: {error})")
        return CacheLookup(line, path)

    def store(self, key: LineKey, line: RacingLine) -> Path:
        """Write the entry whole or not at all (a temporary file renamed over the old one)."""
        path = self.path(line.track, key)
        self.folder.mkdir(parents=True, exist_ok=True)
        header = {
            "key": key.digest,
            "track": line.track,
            "lap_time_s": line.lap_time_s,
            "standing_laps_s": list(line.standing_laps_s),
            "centre_line_lap_time_s": line.centre_line_lap_time_s,
            "min_clearance_m": line.min_clearance_m,
            "max_curvature_per_m": line.max_curvature_per_m,
            "optimiser_iterations": line.optimiser_iterations,
        }
        handle, temporary = tempfile.mkstemp(dir=self.folder, suffix=".npz.part")
        try:
            with os.fdopen(handle, "wb") as file:
                np.savez(file, header=np.array(json.dumps(header)), **{name: getattr(line, name) for name in _ARRAYS})
            os.replace(temporary, path)
        finally:
            Path(temporary).unlink(missing_ok=True)  # gone already once renamed
        return path


def _line_of(header: dict, arrays: dict[str, np.ndarray], key: LineKey) -> RacingLine:
    """The entry as a line, checked: its key, its arrays' shapes and values."""
    if header.get("key") != key.digest:
        raise ValueError(f"the entry's key {header.get('key')!r} is not {key.digest!r}")
    points = arrays["points_m"]
    count = points.shape[0]
    if points.shape != (count, 2) or count < 3:
        raise ValueError(f"points_m has shape {points.shape}, not (N >= 3, 2)")
    for name in ("speeds_mps", "curvatures_per_m"):
        if arrays[name].shape != (count,):
            raise ValueError(f"{name} has shape {arrays[name].shape}, not ({count},)")
    if not all(np.all(np.isfinite(values)) for values in arrays.values()) or np.any(arrays["speeds_mps"] <= 0):
        raise ValueError("non-finite values or a speed not above 0")
    return RacingLine(
        track=str(header["track"]),
        limits=key.limits,
        points_m=points,
        speeds_mps=arrays["speeds_mps"],
        lap_time_s=float(header["lap_time_s"]),
        standing_laps_s=tuple(float(t) for t in header["standing_laps_s"]),
        centre_line_lap_time_s=float(header["centre_line_lap_time_s"]),
        min_clearance_m=float(header["min_clearance_m"]),
        max_curvature_per_m=float(header["max_curvature_per_m"]),
        optimiser_iterations=int(header["optimiser_iterations"]),
        curvatures_per_m=arrays["curvatures_per_m"],
    )


@dataclass(frozen=True)
class CachedLine:
    """A line and where it came from."""

    line: RacingLine
    path: Path
    from_cache: bool
    problem: str | None
    """Why an entry that was there was computed again, or None."""


def cached_racing_line(
    track: Track,
    key: LineKey,
    cache: LineCache,
    on_progress: ProgressCallback | None = None,
) -> CachedLine:
    """The line from the cache, else computed (`racing_line` with the key's settings) and kept there."""
    found = cache.load(track.name, key)
    if found.line is not None:
        return CachedLine(found.line, found.path, True, None)
    line = racing_line(track, key.limits, key.spacing_m, key.control_spacings_m, on_progress)
    return CachedLine(line, cache.store(key, line), False, found.problem)
