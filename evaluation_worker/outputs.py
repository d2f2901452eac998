"""Where an evaluation's files go and what they contain: layout, simtrace, EvaluationMetrics, summary, table.

Layout under the model prefix (DeepRacer-for-Cloud's evaluation layout; docs/evaluation.md):

    <prefix>/metrics/evaluation/evaluation-<ts>.json             DeepRacer's schema (s3_metrics.py), one entry per lap
    <prefix>/evaluation-<ts>/evaluation-simtrace/0-iteration.csv  19-column simtrace of every step
    <prefix>/evaluation-<ts>/summary.json                         what ran and its laps (summit rule: laps, best lap,
                                                                  resets per lap, total progress), timings, file keys
    <prefix>/evaluation-<ts>/evaluation_params.yaml               the job's settings as DeepRacer yaml keys (strings)
    <prefix>/evaluation-<ts>/camera-incar/0-video.mp4             videos (DeepRacer's camera-<view>/<n>-video.mp4 names)
    <prefix>/evaluation-<ts>/camera-topview/0-video.mp4
    <prefix>/evaluation-<ts>/camera-45degree/0-video.mp4
    <prefix>/evaluation-<ts>/evaluation.mcap                      Foxglove recording

`<ts>` is the UTC start time `YYYYmmddHHMMSS`; a second evaluation started within the same second takes the next free
second (racer's earlier runs may have a `-2` suffix and their metrics at `metrics/EvaluationMetrics-<ts>.json`).
Videos and the recording sit in the evaluation folder (not `<prefix>/mp4/`) so that one evaluation's files stay
together and several evaluations of one model never overwrite each other's `0-video.mp4`.
"""

from __future__ import annotations

import datetime as dt
from dataclasses import asdict
from typing import Any

from racer.evaluation_worker.config import EvaluationConfig
from racer.evaluation_worker.driver import StepRecord
from racer.evaluation_worker.laps import LapResult
from racer.evaluation_worker.summit_rule import SummitResult
from racer.shared import model_layout
from racer.shared.deepracer.episode_status import EpisodeStatus
from racer.shared.deepracer.metrics import EvaluationMetrics, EvaluationMetricsEntry
from racer.shared.deepracer.simtrace import SimtraceWriter
from racer.shared.model_layout import EvaluationLayout
from racer.shared.sim.env import DeepRacerEnv
from racer.shared.store import ObjectStore, join_key


def choose_run_name(store: ObjectStore, model_prefix: str, started: dt.datetime) -> str:
    """`evaluation-<ts>` of the start time, or of the next second free of an evaluation folder and metrics file.

    A later second rather than a suffix (`-2`): deepracer-utils reads an evaluation only from a folder named with
    exactly 14 digits (model_layout.EVALUATION_TIMESTAMP_FORMAT)."""
    moment = started
    while True:
        timestamp = moment.strftime(model_layout.EVALUATION_TIMESTAMP_FORMAT)
        folder = join_key(model_prefix, model_layout.evaluation_folder(timestamp))
        metrics = join_key(model_prefix, model_layout.evaluation_metrics(timestamp))
        if not store.list_keys(folder + "/") and not store.exists(metrics):
            return model_layout.evaluation_folder(timestamp)
        moment += dt.timedelta(seconds=1)


class SimtraceRecorder:
    """A StepObserver collecting the evaluation simtrace (all steps; DeepRacer uploads it once at the end)."""

    def __init__(self) -> None:
        self.writer = SimtraceWriter()

    def before_step(self, env: DeepRacerEnv) -> None:
        """Nothing to capture before the step."""

    def on_step(self, record: StepRecord) -> None:
        self.writer.add_row(record.row)

    def close(self) -> None:
        """The rows stay in memory until written."""


def evaluation_metrics(laps: list[LapResult] | tuple[LapResult, ...]) -> EvaluationMetrics:
    return EvaluationMetrics(
        EvaluationMetricsEntry.from_lap(
            progress_pct=lap.progress_pct,
            start_time_s=lap.start_time_s,
            end_time_s=lap.end_time_s,
            status=EpisodeStatus(lap.status),
            trial=lap.trial,
            crash_count=lap.crash_count,
            immobilized_count=lap.immobilized_count,
            off_track_count=lap.off_track_count,
            reversed_count=lap.reversed_count,
        )
        for lap in laps
    )


def evaluation_params(config: EvaluationConfig, layout: EvaluationLayout, checkpoint: str | None) -> dict[str, object]:
    """The job as an evaluation_params.yaml would describe it (SimApp keys, string values as DRfC writes them).

    The summit rule keeps DeepRacer's keys where they mean the same (NUMBER_OF_RESETS = put-backs per lap,
    RACE_DURATION) and says which rule ran in RACER_EVALUATION_MODE.
    """
    params = {
        "JOB_TYPE": "EVALUATION",
        "RACE_TYPE": config.challenge.race_type,
        "WORLD_NAME": str(config.track),
        "RACER_WORLD": config.world,
        "REVERSE_DIR": str(config.reverse_dir).lower(),
        "MODEL_S3_PREFIX": layout.model_prefix,
        "EVAL_CHECKPOINT": config.checkpoint if checkpoint is not None else "",
        "METRICS_S3_OBJECT_KEY": layout.key(layout.relative("metrics")),
        "SIMTRACE_S3_PREFIX": layout.key(layout.run_name),
        "MP4_S3_OBJECT_PREFIX": layout.key(layout.run_name),
        "RACER_EVALUATION_MODE": config.mode,
        "RACER_CAR_PROFILE": config.car_profile,
        "RACER_GENERATION": config.generation,
    }
    if config.challenge.has_objects:
        params.update(config.challenge.to_training_params())  # OBJECT_POSITIONS stays a YAML list
    if config.mode == "race":
        summit = config.summit
        params.update(
            {
                "RACE_DURATION": str(summit.race_duration_s),
                "NUMBER_OF_RESETS": str(summit.resets_per_lap),
                "OFF_TRACK_PENALTY": str(summit.reset_penalty_s),
                "RACER_PUT_BACK": summit.put_back,
                "IS_CONTINUOUS": str(summit.continuous).lower(),
            }
        )
    else:
        rules = config.deepracer
        params.update(
            {
                "NUMBER_OF_TRIALS": str(rules.number_of_trials),
                "IS_CONTINUOUS": str(rules.is_continuous).lower(),
                "NUMBER_OF_RESETS": str(rules.number_of_resets),
                "OFF_TRACK_PENALTY": str(rules.off_track_penalty_s),
                "COLLISION_PENALTY": str(rules.collision_penalty_s),
                "IMMOBILIZED_PENALTY": str(rules.immobilized_penalty_s),
            }
        )
    return params


def _round(value: float | None, digits: int = 3) -> float | None:
    return None if value is None else round(float(value), digits)


def lap_dict(lap: LapResult) -> dict[str, Any]:
    return {
        "lap": lap.lap_index + 1,
        "trial": lap.trial,
        "status": lap.status,
        "label": lap.label,
        "completed": lap.completed,
        "lap_time_s": _round(lap.lap_time_s),
        "elapsed_s": _round(lap.elapsed_s),
        "progress_pct": _round(lap.progress_pct),
        "put_backs": lap.put_backs,
        "off_track_count": lap.off_track_count,
        "crash_count": lap.crash_count,
        "immobilized_count": lap.immobilized_count,
        "reversed_count": lap.reversed_count,
        "reset_count": lap.reset_count,
        "start_time_s": _round(lap.start_time_s),
        "end_time_s": _round(lap.end_time_s),
        "steps": lap.steps,
        "reward_score": round(lap.total_reward, 3),
    }


def lap_statistics(laps: list[LapResult] | tuple[LapResult, ...], track_length_m: float) -> dict[str, Any]:
    """Numbers both modes report: completed laps, best/average lap time, total progress and distance."""
    times = [lap.lap_time_s for lap in laps if lap.lap_time_s is not None]
    total_progress = sum(min(lap.progress_pct, 100.0) for lap in laps)
    return {
        "laps_completed": len(times),
        "best_lap_time_s": _round(min(times)) if times else None,
        "average_lap_time_s": _round(sum(times) / len(times)) if times else None,
        "total_progress_pct": _round(total_progress),
        "total_distance_m": _round(total_progress / 100.0 * track_length_m),
        "put_backs": sum(lap.put_backs for lap in laps),
    }


def summary_dict(
    *,
    mode: str,
    header: dict[str, Any],
    rules: Any,
    laps: list[LapResult] | tuple[LapResult, ...],
    summit: SummitResult | None,
    track_length_m: float,
    timings: dict[str, Any],
    files: dict[str, Any],
) -> dict[str, Any]:
    summary: dict[str, Any] = {"mode": mode, **header, "rules": asdict(rules)}
    summary.update(lap_statistics(laps, track_length_m))
    if summit is not None:
        summary["race"] = {
            "race_start_s": _round(summit.race_start_s),
            "race_end_s": _round(summit.race_end_s),
            "ended_by": "time_up"
            if summit.laps and summit.laps[-1].status == "time_up"
            else "no time left for another attempt",
        }
    summary["laps"] = [lap_dict(lap) for lap in laps]
    summary["timings"] = timings
    summary["files"] = files
    return summary


def format_table(laps: list[LapResult] | tuple[LapResult, ...], track_length_m: float) -> str:
    """The table printed at the end: lap, time, resets, progress, status; then the totals."""
    header = f"{'lap':>4}  {'time (s)':>9}  {'resets':>6}  {'progress':>9}  status"
    lines = [header, "-" * (len(header) + 8)]
    for lap in laps:
        time_text = (
            f"{lap.lap_time_s:9.3f}" if lap.lap_time_s is not None else f"{'(' + format(lap.elapsed_s, '.3f') + ')':>9}"
        )
        lines.append(f"{lap.lap_index + 1:>4}  {time_text}  {lap.put_backs:>6}  {lap.progress_pct:>8.2f}%  {lap.label}")
    stats = lap_statistics(laps, track_length_m)
    best = stats["best_lap_time_s"]
    lines.append("-" * (len(header) + 8))
    lines.append(
        f"laps completed {stats['laps_completed']}, best lap {'-' if best is None else format(best, '.3f') + ' s'}, "
        f"total progress {stats['total_progress_pct']:.2f}% ({stats['total_distance_m']:.2f} m), "
        f"put back {stats['put_backs']} times"
    )
    return "\n".join(lines)
