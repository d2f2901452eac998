"""`python -m benchmarks fidelity` (`simtrace_replay`): the open-loop replay of real simtraces through racer's car, per
speed band.
How its car was fitted and what limits it are studies in the repository's research/ (tyre_fit, replay_limits)."""
