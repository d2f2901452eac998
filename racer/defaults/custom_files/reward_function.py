"""Default reward: stay near the centre line, keep all wheels on the track, keep moving forward.

This is an ordinary DeepRacer reward function: `reward_function(params) -> float`, with the
params dict of the AWS DeepRacer console. Replace it with your own.
"""

import math


def reward_function(params):
    if params["is_offtrack"] or not params["all_wheels_on_track"]:
        return 1e-3

    # 1.0 on the centre line, falling smoothly to ~0.1 at the border.
    half_width = 0.5 * params["track_width"]
    offset = min(params["distance_from_center"] / half_width, 1.0)
    centre_term = math.exp(-2.3 * offset * offset)

    # Small bonus for progress made per step, so driving forward beats dithering.
    steps = max(params["steps"], 1.0)
    pace_term = min(params["progress"] / steps, 1.0)

    return float(centre_term + 0.5 * pace_term)
