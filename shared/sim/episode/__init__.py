"""The episode's rules around the physics: phases, starts, reset rules, the judged pose and the step's row."""
