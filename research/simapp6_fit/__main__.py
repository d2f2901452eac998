"""`python -m research.simapp6_fit`: fit the simapp6 car on the 2026 logs, each file held out in turn."""

from research.simapp6_fit.study import simapp6_fit_command

simapp6_fit_command(prog_name="python -m research.simapp6_fit")
