"""`python -m research.replay_limits`: what the real simtraces allow any car model, per speed band."""

from research.replay_limits.study import replay_limits_command

replay_limits_command(prog_name="python -m research.replay_limits")
