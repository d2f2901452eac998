"""The car's fastest line round a track and its speed profile: the fastest lap the car's own limits allow, whoever
drives it (`racer track line` writes it for users; `python -m benchmarks race-pace` judges a policy against it).

Why: a policy's best lap says little alone; against what the same car could do on the same track it says how much is
left. The model is the textbook quasi-steady point mass on a racing line, in rooms:

* `limits`: the car's limits (`CarLimits.of_car`), read from the car profile and the world;
* `speed_profile`: the fastest speeds along a line, a forward (drive) and a backward (brake) pass under each station's
  grip and top-speed ceiling, and the laps from rest;
* `optimiser`: the line as a spline through offsets along the centre line's normals, chosen by SLSQP coarse to fine;
* `line`: `racing_line()` and what a user reads off the result (`RacingLine`);
* `cache`, `export`, `picture`: the line kept in racer's cache, written as csv/npy/json, and drawn.
"""

from racer.racing_line.limits import CarLimits, LapTimeBoundError, profile_name
from racer.racing_line.line import RacingLine, racing_line
from racer.racing_line.optimiser import CONTROL_SPACINGS_M, DEFAULT_SPACING_M, OptimiserProgress
from racer.racing_line.speed_profile import PREPARE_STEP_S, STANDING_START_LAPS, path_speeds, standing_start_laps

__all__ = [
    "CONTROL_SPACINGS_M",
    "DEFAULT_SPACING_M",
    "PREPARE_STEP_S",
    "STANDING_START_LAPS",
    "CarLimits",
    "LapTimeBoundError",
    "OptimiserProgress",
    "RacingLine",
    "path_speeds",
    "profile_name",
    "racing_line",
    "standing_start_laps",
]
