"""racer's race-pace reward (racer/defaults/racing): pays for speed along the track, and for a fast lap at its end.

Each step earns the commanded speed along the track over 4 m/s: the rate of progress the params can tell without
remembering the previous step (DeepRacer's `speed` is the action's speed; the track's direction is the segment between
the two closest waypoints). Summed over a lap this is the same at any speed (a lap at average speed v takes
L / (v dt) steps), so what it pays for is getting round: a car that leaves the track loses the rest of the lap. The
step that completes the lap adds a bonus for its pace: the steps a lap takes at 4 m/s along the centre line, times
that number over the steps it took, so a lap at top speed doubles the lap's pay and one at half of it adds half.
A reward growing with speed at every step instead (speed squared, say) pays a car that flies off the first bend at
4 m/s almost what it pays a slower whole lap, and teaches just that. Leaving the track ends the episode; the off-track
step earns the minimum. Imports math only, as DeepRacer on AWS allows.
"""

import math

TOP_SPEED_MPS = 4.0
"""DeepRacer's fastest action: a step at it, straight along the track, earns 1."""
STEP_S = 1.0 / 15.0
"""DeepRacer calls the reward 15 times a simulated second."""
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
    reward = max(along_track_mps / TOP_SPEED_MPS, MIN_REWARD)
    if params["progress"] >= 100.0:
        steps_at_top_speed = params["track_length"] / (TOP_SPEED_MPS * STEP_S)
        reward += steps_at_top_speed * steps_at_top_speed / max(params["steps"], 1)
    return float(reward)
