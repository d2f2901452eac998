"""Calibration research beside the benchmarks: `racer bench fidelity` (`replay`: open-loop replay of real simtraces
through racer's car) and the studies it reports: the heading yardstick (`floor`), the logs' timing noise and the
error floor of an exact model (`noise`), the replay's hypotheses (`hypotheses`) and the tyre-constant fit on the
logs (`tyre_fit`)."""
