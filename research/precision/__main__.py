"""`python -m research.precision`: env steps to 3 of 3 greedy laps per tower precision and seed."""

from research.precision.learn_to_lap import precision_command

precision_command(prog_name="python -m research.precision")
