"""`python -m research.console2020_fit`: fit the 2019 generation's car on the 2020 console log, episodes held out."""

from research.console2020_fit.study import console2020_fit_command

console2020_fit_command(prog_name="python -m research.console2020_fit")
