"""`python -m research.tyre_fit`: fit the car's constants to real simtraces, or screen the replay's hypotheses."""

from research.tyre_fit.study import tyre_fit_command

tyre_fit_command(prog_name="python -m research.tyre_fit")
