"""DeepRacer on AWS's ranking on hand-made laps: each timing method, the consecutive-laps mean, unranked entrants."""

from __future__ import annotations

from racer.race.ranking import Lap, best_average_lap_ms, max_consecutive_completed, rank_entrants, submission_stats


def laps(*times_ms: int | None) -> list[Lap]:
    """A completed lap per number; None is a lap that ended short (50 %, 4 s)."""
    return [Lap(100, t, reset_count=1) if t is not None else Lap(50, 4000, off_track_count=1) for t in times_ms]


def test_the_consecutive_laps_mean_skips_windows_with_an_unfinished_lap():
    run = laps(10000, 12000, None, 11000, 9000, 9500)
    assert max_consecutive_completed(run) == 3
    assert best_average_lap_ms(run, 2) == 9250  # laps 5 and 6
    assert best_average_lap_ms(run, 3) == 9833  # floor of 29500 / 3, laps 4-6 (not 1-3: lap 3 is short)
    assert best_average_lap_ms(run, 4) is None
    assert best_average_lap_ms(laps(10000, 12000, 11000, 9000), 2) == 10000  # DRoA's own test case


def test_stats_use_droa_names_and_totals():
    stats = submission_stats(laps(10000, None, 8000), minimum_laps=1)
    assert stats.bestLapTime == 8000  # the fastest completed lap: the 4 s short lap does not count
    assert stats.totalLapTime == 22000 and stats.lapCount == 3
    assert (stats.resetCount, stats.offTrackCount, stats.completedLapCount) == (2, 1, 1)


def test_each_timing_method_ranks_lower_first_and_needs_minimum_laps():
    field = [
        ("steady", laps(10000, 10000, 10000), None, None),
        ("flash", laps(8000, 13000, 12500), None, None),
        ("patchy", laps(7000, None, 9000), None, None),
        ("broken", None, "racer model import failed", "COACH_CHECKPOINT_DOES_NOT_EXIST"),
    ]

    def order(method, minimum):
        return [(s.rank, s.entrant) for s in rank_entrants(field, timing_method=method, minimum_laps=minimum)]

    assert order("BEST_LAP_TIME", 1) == [(1, "patchy"), (2, "flash"), (3, "steady"), (None, "broken")]
    # AVG over 2 consecutive laps: steady 10000, flash 10500; patchy has no two in a row.
    assert order("AVG_LAP_TIME", 2) == [(1, "steady"), (2, "flash"), (None, "patchy"), (None, "broken")]
    # TOTAL_TIME: the sum of every lap; patchy has 1 consecutive completed lap only, minimumLaps 3 is not met.
    assert order("TOTAL_TIME", 3) == [(1, "steady"), (2, "flash"), (None, "patchy"), (None, "broken")]
    standings = rank_entrants(field, timing_method="TOTAL_TIME", minimum_laps=3)
    patchy, broken = standings[2], standings[3]
    assert patchy.dnf_reason == "1 consecutive completed lap, 3 needed (minimumLaps)"
    assert (broken.stats, broken.error_code) == (None, "COACH_CHECKPOINT_DOES_NOT_EXIST")
    assert standings[0].score_ms == 30000


def test_ties_rank_by_name_and_a_failure_with_laps_is_unranked():
    field = [("b", laps(9000), None, None), ("a", laps(9000), None, None), ("nan", laps(5000), "NaN policy", None)]
    standings = rank_entrants(field, timing_method="BEST_LAP_TIME", minimum_laps=1)
    assert [(s.rank, s.entrant) for s in standings] == [(1, "a"), (2, "b"), (None, "nan")]
    assert standings[2].dnf_reason == "NaN policy"
