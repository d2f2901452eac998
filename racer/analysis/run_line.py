"""A run's racing line: the car and world its params name, on the route it drove, computed once per (route, car,
world) by a `LineBook` (racer.racing_line; a line takes tens of seconds on a big track).

The car is known only from racer's own keys (RACER_GENERATION, RACER_CAR_PROFILE): a DeepRacer run's params name
neither, and its car is DeepRacer's, which racer's line does not model; such a run gets a note, not a line.
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass

from racer.racing_line import CarLimits, LapTimeBoundError, RacingLine, racing_line
from racer.shared.sim.tracks.track import Track
from racer.shared.worker_settings import WorkerSettings

CAR_KEYS = ("RACER_GENERATION", "RACER_CAR_PROFILE")
"""The params keys that say which car drove: racer writes them; DeepRacer's SimApp does not."""

LineMaker = Callable[[Track, CarLimits], RacingLine]


@dataclass(frozen=True)
class RunCar:
    """What a run's line depends on: the route as driven (reversed when REVERSE_DIR), the car's limits in its world."""

    track: Track
    limits: CarLimits

    @property
    def key(self) -> tuple:
        route = hashlib.sha1(self.track.waypoints.tobytes()).hexdigest()
        return (self.track.name, route, self.limits)

    def describe(self) -> str:
        direction = ", reversed" if self.track.direction_reversed else ""
        return f"{self.track.name}{direction}, car {self.limits.car_profile}, {self.limits.world} world"


def run_car(params: Mapping[str, object], source: str, track: Track) -> RunCar | str:
    """The car and route of a run whose params (training_params / evaluation_params keys) are `params`, on `track`
    (the route the analysis draws, in its file's direction); a sentence saying why not when the params cannot tell."""
    if not any(str(params.get(key) or "").strip() for key in CAR_KEYS):
        return (
            f"{source} names no racer car ({' or '.join(CAR_KEYS)}): a DeepRacer run's car is not the one racer's "
            "line models"
        )
    try:
        settings = WorkerSettings.from_training_params(params, source)
        limits = CarLimits.of_car(settings.car_dynamics, world=settings.world)
    except ValueError as error:
        return str(error)
    return RunCar(track.reversed() if settings.reverse_dir else track, limits)


class LineBook:
    """The lines one analysis (or one viewer) needs, each computed once; a line that cannot be computed is kept as
    its reason, so it is not tried again."""

    def __init__(self, make: LineMaker = racing_line) -> None:
        self._make = make
        self._lines: dict[tuple, RacingLine | str] = {}

    def line(self, car: RunCar) -> RacingLine | str:
        """The car's line on its route, or why there is none (LapTimeBoundError's message)."""
        if car.key not in self._lines:
            try:
                self._lines[car.key] = self._make(car.track, car.limits)
            except LapTimeBoundError as error:
                self._lines[car.key] = str(error)
        return self._lines[car.key]

    def known(self, car: RunCar) -> RacingLine | str | None:
        """The line if it was computed already, else None (the viewer asks without waiting)."""
        return self._lines.get(car.key)


def ratio_to_bound(lap_time_s: float | None, line: RacingLine | None) -> float | None:
    """A lap over the line's flying lap: 1.0 would be the car's fastest lap (a best lap may be a flying one)."""
    if lap_time_s is None or line is None:
        return None
    return round(lap_time_s / line.lap_time_s, 3)
