"""A multi-car evaluation from the store: one `EvaluationSession` per car, raced together by `multi_car.run_multi_car`.

    reports, result = run_multi_car_evaluation(store, [config_of_model, config_of_opponent], MultiCarRules())

Car 0 is the first config (the front of the grid). Each car's files (metrics, simtrace, summary, videos, MCAP) are
written under its own model prefix as `racer evaluate` writes them; its summary also carries the race: the race type,
the car's place on the grid, its finishing place and the whole finishing order.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from pathlib import Path

from racer.evaluation_worker.config import EvaluationConfig
from racer.evaluation_worker.driver import EvaluationDriver, ProgressLog, no_log
from racer.evaluation_worker.laps import LapResult, describe_lap
from racer.evaluation_worker.multi_car import MultiCarResult, MultiCarRules, run_multi_car
from racer.evaluation_worker.multi_car_video import AllCarsTopView
from racer.evaluation_worker.runner import EvaluationReport, EvaluationSession
from racer.shared.deepracer.model_metadata import ModelMetadata
from racer.shared.policy.protocol import Policy
from racer.shared.policy.torch_threads import one_torch_thread_if_loaded
from racer.shared.sim.objects.peer_cars import PeerCars
from racer.shared.store import ObjectStore


def run_multi_car_evaluation(
    store: ObjectStore,
    configs: Sequence[EvaluationConfig],
    rules: MultiCarRules,
    *,
    policies: Sequence[tuple[Policy, ModelMetadata]] | None = None,
    out_dir: Path | None = None,
    log: ProgressLog = no_log,
    attach: Callable[[int, EvaluationDriver], None] | None = None,
    top_view: Path | None = None,
) -> tuple[list[EvaluationReport], MultiCarResult]:
    """Race the configs' models (deepracer mode: the reset budget and penalties of `config.deepracer`; laps from
    `rules`). `policies` replaces the stored networks (tests; `attach(i, driver)` hands a scripted one its driver). `out_dir` keeps a local copy per car (`car-<i>/`). `top_view`: the
    all-cars top-view MP4 written there (`multi_car_video`; with the first config's video options)."""
    if len(configs) < 2:
        raise ValueError(f"{rules.race_type} needs two or more models")
    peers = [PeerCars(i, len(configs)) for i in range(len(configs))]
    sessions: list[EvaluationSession] = []
    try:
        for i, config in enumerate(configs):
            policy, metadata = policies[i] if policies is not None else (None, None)
            sessions.append(
                EvaluationSession(
                    store,
                    config,
                    policy=policy,
                    model_metadata=metadata,
                    out_dir=None if out_dir is None else out_dir / f"car-{i}",
                    track_objects=peers[i],
                )
            )
    except BaseException:
        for session in sessions:
            session.driver.close()
            session.env.close()
        raise
    for i, session in enumerate(sessions):
        if attach is not None:
            attach(i, session.driver)
        log(f"car {i}: {session.layout.model_prefix} checkpoint {session.checkpoint or '(given policy)'}")
    one_torch_thread_if_loaded()

    def lap_logger(i: int):
        def on_lap(lap: LapResult) -> None:
            log(f"car {i} " + describe_lap(lap))

        return on_lap

    field_view = None
    if top_view is not None:
        names = [config.model_prefix.rsplit("/", 1)[-1] for config in configs]
        field_view = AllCarsTopView(sessions[0].env, top_view, names, configs[0].video)
    started = time.perf_counter()
    try:
        result = run_multi_car(
            [s.driver for s in sessions],
            peers,
            rules,
            [lap_logger(i) for i in range(len(sessions))],
            on_tick=None if field_view is None else field_view.add,
        )
    finally:
        if field_view is not None:
            field_view.close()
        for session in sessions:
            session.driver.close()
            session.env.close()
    wall_s = time.perf_counter() - started
    reports = []
    for session, car in zip(sessions, result.cars, strict=True):
        place = result.finishing_order.index(car.index) + 1
        race_summary = {
            "race_type": rules.race_type,
            "laps": rules.laps,
            "grid_place": car.index + 1,
            "finishing_place": place,
            "finished": car.finished,
            "parked": car.parked,
            "finishing_order": [configs[i].model_prefix for i in result.finishing_order],
        }
        reports.append(session.finish(car.laps, None, wall_s, {"multi_car": race_summary}))
    log(describe_result(result, [c.model_prefix for c in configs]))
    return reports, result


def describe_result(result: MultiCarResult, names: Sequence[str]) -> str:
    """The finishing order as lines: place, model, laps, finish time or distance raced, crashes."""
    lines = [f"{result.rules.race_type}: {result.rules.laps} lap(s)"]
    for place, index in enumerate(result.finishing_order, start=1):
        car = result.cars[index]
        end = (
            f"finished {car.finish_time_s:8.3f} s" if car.finish_time_s is not None else f"raced {car.raced_pct:6.1f} %"
        )
        lines.append(f"{place:2d}. {names[index]:<30} laps {car.laps_completed}  {end}  crashes {car.crash_count}")
    return "\n".join(lines)
