"""`racer bench viewer`'s arithmetic: each load-on iteration against its load-off neighbours, steps per phase."""

from racer.viewer.bench import _paired_ratios, _phase_steps


def records(rates: list[float], on: list[bool], steps: list[int]) -> list[dict]:
    total, rows = 0, []
    for rate, load_on, played in zip(rates, on, steps, strict=True):
        total += played
        rows.append({"experience_steps_per_s": rate, "load_on": load_on, "env_steps_total": total})
    return rows


def test_each_load_on_iteration_is_compared_with_its_load_off_neighbours():
    rows = records([100.0, 90.0, 120.0, 99.0, 110.0], [False, True, False, True, False], [10] * 5)
    assert _paired_ratios(rows) == [90.0 / 110.0, 99.0 / 115.0]
    # at the edge only one neighbour exists; two load-on iterations in a row are not neighbours of each other
    rows = records([100.0, 80.0, 70.0], [False, True, True], [10] * 3)
    assert _paired_ratios(rows) == [0.8]


def test_steps_per_phase_come_from_the_running_total_after_the_warm_up():
    rows = records([1.0] * 5, [False, False, True, False, True], [7, 11, 13, 17, 19])
    assert _phase_steps(rows, warmup_iterations=2, on=True) == 13 + 19
    assert _phase_steps(rows, warmup_iterations=2, on=False) == 17
