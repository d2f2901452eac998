"""Multi-car races (HEAD_TO_MODEL, F1) with scripted cars on the small oval: the SimApp's single-file start, crashes
between cars counted for the car at fault, F1's parking and finishing order, and the same result for the same seed."""

from __future__ import annotations

import pytest

from racer.evaluation_worker.config import EvaluationConfig
from racer.evaluation_worker.driver import EvaluationDriver
from racer.evaluation_worker.multi_car import (
    START_POS_OFFSET_M,
    CarRun,
    MultiCarError,
    MultiCarRules,
    finishing_order,
    run_multi_car,
)
from racer.shared.run_settings import env_config
from racer.shared.sim.env import DeepRacerEnv
from racer.shared.sim.objects.peer_cars import PeerCars, car_name
from tests.evaluation.scripted import CONTINUOUS_METADATA, ScriptedPolicy


class _Rows:
    """Keeps each step's simtrace row."""

    def __init__(self) -> None:
        self.rows: list[dict] = []

    def before_step(self, env) -> None:
        pass

    def on_step(self, record) -> None:
        self.rows.append(dict(record.row))

    def close(self) -> None:
        pass


def _race(speeds: list[float], rules: MultiCarRules, seed: int = 0):
    config = env_config(*EvaluationConfig(model_prefix="x", track="racer_oval").run_settings(CONTINUOUS_METADATA))
    drivers, peers = [], []
    for index, speed in enumerate(speeds):
        peer_cars = PeerCars(index, len(speeds))
        policy = ScriptedPolicy(speed)
        driver = EvaluationDriver(DeepRacerEnv(config, track_objects=peer_cars), policy, [_Rows()], seed=seed)
        policy.attach(driver)
        drivers.append(driver)
        peers.append(peer_cars)
    try:
        return run_multi_car(drivers, peers, rules), drivers
    finally:
        for driver in drivers:
            driver.env.close()


def test_each_env_draws_the_other_cars_and_only_them():
    peer_cars = PeerCars(1, 3)
    assert [slot.name for slot in peer_cars.slots] == [car_name(0), car_name(2)]


def test_head_to_model_rear_end_counts_for_the_car_behind():
    # A fast car starts on the grid right behind a slow one: it runs into it from behind, is at fault and pauses; the
    # slow car ahead is hit but goes on, and finishes first (DONE_CONDITION any ends the race for both).
    result, drivers = _race([1.0, 3.0], MultiCarRules("HEAD_TO_MODEL", laps=1))
    slow, fast = result.cars
    assert fast.crash_count >= 1
    assert slow.crash_count == 0
    assert slow.finished and not fast.finished and not slow.parked
    assert result.finishing_order == (0, 1)
    # The grid: car 0 on the line (outer lane), car 1 START_POS_OFFSET behind it (inner lane), progress below 0.
    rows = [driver.observers[0].rows for driver in drivers]
    length_m = drivers[0].core.track.length_m
    gap_pct = rows[0][0]["progress"] - rows[1][0]["progress"]  # both judged at the car's front
    assert gap_pct == pytest.approx(100.0 * START_POS_OFFSET_M / length_m, abs=0.5)
    assert rows[1][0]["progress"] < 0.0


def test_f1_parks_finished_cars_and_ranks_by_finishing_order():
    result, _ = _race([2.0, 3.0, 1.0], MultiCarRules("F1", laps=1))
    assert all(car.finished and car.parked for car in result.cars)
    times = {car.index: car.finish_time_s for car in result.cars}
    assert list(result.finishing_order) == sorted(times, key=lambda i: times[i])
    assert result.cars[1].crash_count >= 1  # the fast car caught the one ahead of it on the grid
    # Car 2 (1 m/s, 1.5 m behind the line) drives its grid gap too: its lap is longer than the line-to-line lap.
    assert result.cars[2].laps[0].elapsed_s > result.cars[0].laps[0].elapsed_s


def test_same_seed_same_result():
    rules = MultiCarRules("F1", laps=1)
    first, _ = _race([2.0, 3.0], rules, seed=3)
    second, _ = _race([2.0, 3.0], rules, seed=3)
    assert first == second


def test_rules_refuse_bad_values():
    with pytest.raises(MultiCarError, match="RACE_TYPE"):
        MultiCarRules("TIME_TRIAL")
    with pytest.raises(MultiCarError, match="START_POS_OFFSET"):
        MultiCarRules("F1", start_pos_offset_m=2.0)
    assert MultiCarRules("F1").waits_for_all and not MultiCarRules("HEAD_TO_MODEL").waits_for_all


def test_finishing_order_puts_finishers_first_then_distance():
    def run(index, finished, time_s, raced):
        return CarRun(index, (), finished, time_s, finished, raced)

    cars = [run(0, False, None, 80.0), run(1, True, 30.0, 100.0), run(2, True, 20.0, 100.0), run(3, False, None, 90.0)]
    assert finishing_order(cars) == (2, 1, 3, 0)


def test_multi_car_evaluation_writes_each_cars_files(tmp_path):
    import json

    from racer.evaluation_worker.config import DeepRacerRules
    from racer.evaluation_worker.multi_car_session import run_multi_car_evaluation
    from racer.shared.store import LocalStore
    from tests.evaluation.conftest import NO_VIDEO

    store = LocalStore(tmp_path)
    configs = [
        EvaluationConfig(model_prefix=name, track="racer_oval", video=NO_VIDEO, mcap=False, deepracer=DeepRacerRules())
        for name in ("slow-model", "fast-model")
    ]
    policies = [ScriptedPolicy(1.0), ScriptedPolicy(3.0)]
    lines: list[str] = []
    reports, result = run_multi_car_evaluation(
        store,
        configs,
        MultiCarRules("HEAD_TO_MODEL"),
        policies=[(p, CONTINUOUS_METADATA) for p in policies],
        log=lines.append,
        attach=lambda i, driver: policies[i].attach(driver),
    )
    assert result.finishing_order == (0, 1)
    slow, fast = (json.loads((tmp_path / r.keys["summary"]).read_bytes()) for r in reports)
    assert slow["multi_car"]["finishing_place"] == 1 and fast["multi_car"]["finishing_place"] == 2
    assert fast["multi_car"]["finishing_order"] == ["slow-model", "fast-model"]
    metrics = json.loads((tmp_path / reports[1].keys["metrics"]).read_bytes())["metrics"]
    assert sum(m["crash_count"] for m in metrics) >= 1
    assert any("1. slow-model" in line for line in lines)


def test_the_time_limit_holds_after_the_front_car_parks():
    # F1: car 0 finishes and parks, its clock stops; the race still ends at max_race_s by the others' clocks.
    full, _ = _race([3.0, 0.5], MultiCarRules("F1", laps=1))
    assert full.cars[0].finished and full.cars[1].finished
    limit_s = (full.cars[0].finish_time_s + full.cars[1].finish_time_s) / 2.0
    result, drivers = _race([3.0, 0.5], MultiCarRules("F1", laps=1, max_race_s=limit_s))
    assert result.cars[0].finished and not result.cars[1].finished
    assert drivers[1].sim_time_s <= limit_s + 0.1
