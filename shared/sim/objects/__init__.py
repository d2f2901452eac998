"""Objects on the track: RACE_TYPE's obstacles and bot cars, other cars of a race, their bodies and crashes."""
