"""racer's race-pace reward (racer/defaults/racing): pays for speed along the track, squared.

A step earns (commanded speed x cos(heading error) / 4 m/s) squared: the rate of progress the params can tell without
remembering the previous step (DeepRacer's `speed` is the action's speed; the track's direction is the segment
between the two closest waypoints). Squared, because the sum over a lap is what training maximises: a lap at average
speed v takes L / (v dt) steps, so a reward linear in v sums to the same for every lap and only the discount would pay
for speed; v squared sums to a total proportional to v. Leaving the track ends the episode (no more reward), which is
the whole penalty; the off-track step itself earns the minimum. Imports math only, as DeepRacer on AWS allows.
"""

import math

TOP_SPEED_MPS = 4.0
"""DeepRacer's fastest action: a step at it, straight along the track, earns 1."""
MIN_REWARD = 1e-3
"""What a step off the track, or one heading backwards, earns (DeepRacer's samples give 1e-3 for such steps)."""


def reward_function(params):
    if params["is_offtrack"]:
        return MIN_REWARD
    waypoints = params["waypoints"]
    behind, ahead = params["closest_waypoints"]
    track_direction_deg = math.degrees(
        math.atan2(waypoints[ahead][1] - waypoints[behind][1], waypoints[ahead][0] - waypoints[behind][0])
    )
    heading_error_deg = (params["heading"] - track_direction_deg + 180.0) % 360.0 - 180.0
    along_track_mps = params["speed"] * math.cos(math.radians(heading_error_deg))
    if along_track_mps <= 0.0:
        return MIN_REWARD
    return float(max((along_track_mps / TOP_SPEED_MPS) ** 2, MIN_REWARD))
