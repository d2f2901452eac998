"""What a rollout worker writes to the store as it plays: DeepRacer's simtrace, TrainingMetrics and best/last.

- `<prefix>[/<worker>]/training-simtrace/<k>-iteration.csv`: every training step of iteration k (19 columns).
- `<prefix>/metrics/TrainingMetrics[_<worker>].json`: one entry per training episode, plus worker 0's
  evaluation episodes (rewritten whole after each iteration, as DeepRacer does after each episode).
- `<prefix>/model/deepracer_checkpoints.json` (worker 0): best checkpoint by BEST_MODEL_METRIC and the last
  evaluated one (deepracer-simapp v5.3.3 `bundle/markov/metrics/s3_metrics.py` TrainingMetrics.update: progress/reward:
  new best if mean >= best; laptime: <=, 999999 ms for no lap).
"""

from __future__ import annotations

import logging

import numpy as np

from racer.rollout_worker.worker_files import WorkerFiles
from racer.shared.deepracer.episode_status import EpisodeStatus
from racer.shared.deepracer.metrics import TrainingMetrics, TrainingMetricsEntry, read_training_metrics
from racer.shared.deepracer.simtrace import SimtraceWriter
from racer.shared.model_layout import CheckpointName
from racer.shared.played_episode import PlayedEpisode
from racer.shared.store import ObjectNotFoundError, ObjectStore

log = logging.getLogger(__name__)

UNFINISHED_LAP_MS = 999_999


class WorkerLog:
    def __init__(self, store: ObjectStore, run: WorkerFiles, worker_id: int):
        self.store = store
        self.run = run
        self.worker_id = worker_id
        self.simtrace = SimtraceWriter()
        self.metrics_key = run.layout.training_metrics(worker_id)
        self.metrics = self._load_metrics()
        self.training_steps = 0
        self._episode = max((e.episode for e in self.metrics.entries), default=0)
        self._trial = 0
        self._trial_iteration = -1

    def _load_metrics(self) -> TrainingMetrics:
        try:
            return read_training_metrics(
                self.store.get_bytes(self.metrics_key), source=f"{self.store.describe()}/{self.metrics_key}"
            )
        except ObjectNotFoundError:
            return TrainingMetrics(best_model_metric=self.run.worker.best_model_metric)

    @property
    def next_training_episode(self) -> int:
        """The simtrace `episode` of the next training episode: the SimApp's running 0-based counter of this
        worker's training episodes (restored from TrainingMetrics on a restart, unaffected by replays)."""
        return self._episode

    @staticmethod
    def _entry(played: PlayedEpisode, episode: int, trial: int, phase: str) -> TrainingMetricsEntry:
        return TrainingMetricsEntry.from_episode(
            total_reward=played.total_reward,
            start_time_s=played.start_time_s,
            end_time_s=played.end_time_s,
            episode=episode,
            trial=trial,
            phase=phase,
            progress_pct=played.progress,
            status=EpisodeStatus(played.final_status),
        )

    def record_training_episode(self, played: PlayedEpisode, iteration: int) -> None:
        if iteration != self._trial_iteration:
            self._trial_iteration, self._trial = iteration, 0
            self.simtrace.clear()  # the previous iteration's rows are uploaded (finish_iteration)
        self._episode += 1
        self._trial += 1
        self.training_steps += played.steps
        self.simtrace.extend(played.simtrace_rows)
        self.metrics.append(self._entry(played, self._episode, self._trial, "training"))

    def finish_iteration(self, iteration: int, num_workers: int) -> None:
        """Upload this iteration's simtrace and the metrics so far. The rows stay until the next iteration's first
        episode, so episodes this worker plays later for the same iteration (claimed from a dead worker) are
        uploaded with them."""
        if len(self.simtrace) and iteration == self._trial_iteration:
            key = self.run.layout.training_simtrace(self.worker_id, iteration, num_workers)
            self.store.put_bytes(key, self.simtrace.to_bytes())
        self.store.put_bytes(self.metrics_key, self.metrics.to_bytes())

    def record_evaluation(self, announcement, results: list[PlayedEpisode], checkpoints, channel) -> None:
        """Worker 0: log the greedy evaluation of checkpoint k and update best/last."""
        for played in results:
            self.metrics.append(self._entry(played, self._episode, self._trial, "evaluation"))
        self.store.put_bytes(self.metrics_key, self.metrics.to_bytes())
        metric_name = self.run.worker.best_model_metric
        if metric_name == "progress":
            value = float(np.mean([p.progress for p in results]))
        elif metric_name == "reward":
            value = float(np.mean([p.total_reward for p in results]))
        else:
            value = float(
                np.mean(
                    [p.lap_time_s * 1000 if p.lap_completed and p.lap_time_s else UNFINISHED_LAP_MS for p in results]
                )
            )
        time_stamp = max(p.end_time_s for p in results)
        best_and_last = checkpoints.record_evaluation(
            announcement.checkpoint, value, time_stamp, higher_is_better=(metric_name != "laptime")
        )
        best = best_and_last.best.name if best_and_last.best else None
        laps = [p for p in results if p.lap_completed]
        checkpoint = CheckpointName.find(announcement.checkpoint)
        record = {
            "iteration": announcement.iteration,
            "checkpoint": announcement.checkpoint,
            "trials": len(results),
            "laps_completed": len(laps),
            "mean_progress": float(np.mean([p.progress for p in results])),
            "avg_eval_metric": value,
            "best_model_metric": metric_name,
            "best_checkpoint": best,
            "best_lap_time_s": min((p.lap_time_s for p in laps if p.lap_time_s), default=None),
            "lap_times_s": [p.lap_time_s if p.lap_completed else None for p in results],
            "statuses": [p.final_status for p in results],
            "progresses": [round(p.progress, 3) for p in results],
            "continuous": self.run.worker.eval_continuous,
            "env_steps_total": checkpoint.env_steps if checkpoint else None,
        }
        channel.publish("evaluations", record)
        log.info(
            "evaluation of %s: %d/%d laps, %s %.2f (best: %s)",
            announcement.checkpoint,
            len(laps),
            len(results),
            metric_name,
            value,
            best,
        )
