"""`TrainingMetrics.json` and `EvaluationMetrics` JSON: one entry per episode (training) or lap (evaluation).

These files drive the console's reward graph and the analysis notebooks, so entries keep DeepRacer's key names,
key order and integer conversions: times are simulation milliseconds `int(round(seconds * 1000))`, the elapsed time
is rounded from the difference of the two clocks (not the difference of the rounded values), `reward_score` is
`int(round(total reward))` and `completion_percentage` is `int(progress)` (truncation). The whole file is rewritten
after every episode as `json.dumps(...)` with default separators and no trailing newline.
Source: deepracer-simapp v5.3.3 `bundle/markov/metrics/s3_metrics.py`.

`completion_percentage` is not floored at 0: an episode whose last step leaves the car behind its start line (turned
round and driven back, then off track, reversed or stopped by a step cap) records a negative value, as the SimApp's
`int(self._progress_)` does with its unclamped step progress (deepracer-simapp v6.0.5 116686f4
`bundle/markov/metrics/s3_metrics.py`, `bundle/markov/agent_ctrl/utils.py` compute_current_prog).
"""

from __future__ import annotations

import json
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from os import PathLike

from racer.shared.deepracer.episode_status import EpisodeStatus

__all__ = [
    "BEST_MODEL_METRICS",
    "EVALUATION_METRICS_KEYS",
    "PHASES",
    "TRAINING_METRICS_KEYS",
    "TRAINING_METRICS_VERSION",
    "EvaluationMetrics",
    "EvaluationMetricsEntry",
    "MetricsError",
    "TrainingMetrics",
    "TrainingMetricsEntry",
    "read_evaluation_metrics",
    "read_training_metrics",
    "sim_time_to_ms",
]


class MetricsError(ValueError):
    """A metrics JSON that cannot be read; the message names the file and the entry/key."""


TRAINING_METRICS_VERSION = 2.0
BEST_MODEL_METRICS: tuple[str, ...] = ("progress", "reward", "laptime")
PHASES: tuple[str, ...] = ("training", "evaluation")
TRAINING_METRICS_KEYS: tuple[str, ...] = (
    "reward_score",
    "metric_time",
    "start_time",
    "elapsed_time_in_milliseconds",
    "episode",
    "trial",
    "phase",
    "completion_percentage",
    "episode_status",
)
EVALUATION_METRICS_KEYS: tuple[str, ...] = (
    "completion_percentage",
    "metric_time",
    "start_time",
    "elapsed_time_in_milliseconds",
    "episode_status",
    "crash_count",
    "immobilized_count",
    "off_track_count",
    "reversed_count",
    "reset_count",
    "trial",
)


def sim_time_to_ms(sim_time_s: float) -> int:
    """Simulation seconds to the integer milliseconds DeepRacer stores."""
    return int(round(sim_time_s * 1000))


@dataclass(frozen=True)
class TrainingMetricsEntry:
    """One episode of TrainingMetrics.json (training episodes and in-training evaluation episodes)."""

    reward_score: int
    metric_time_ms: int
    """Simulation clock when the episode ended."""
    start_time_ms: int
    """Simulation clock when the episode was reset."""
    elapsed_time_ms: int
    episode: int
    """Worker-local training-episode counter, 1-based; evaluation rows repeat the last training episode."""
    trial: int
    """Training episodes since the current iteration started, 1-based; not advanced by evaluation rows."""
    phase: str
    """`training` or `evaluation`."""
    completion_percentage: int
    episode_status: EpisodeStatus

    @classmethod
    def from_episode(
        cls,
        *,
        total_reward: float,
        start_time_s: float,
        end_time_s: float,
        episode: int,
        trial: int,
        phase: str,
        progress_pct: float,
        status: EpisodeStatus,
    ) -> TrainingMetricsEntry:
        """Apply the SimApp's conversions to the raw episode values."""
        if phase not in PHASES:
            raise ValueError(f"phase {phase!r}: allowed: {', '.join(PHASES)}")
        return cls(
            reward_score=int(round(total_reward)),
            metric_time_ms=sim_time_to_ms(end_time_s),
            start_time_ms=sim_time_to_ms(start_time_s),
            elapsed_time_ms=sim_time_to_ms(end_time_s - start_time_s),
            episode=int(episode),
            trial=int(trial),
            phase=phase,
            completion_percentage=int(progress_pct),
            episode_status=EpisodeStatus(status),
        )

    def to_dict(self) -> dict[str, int | str]:
        """DeepRacer's keys in DeepRacer's order."""
        return {
            "reward_score": self.reward_score,
            "metric_time": self.metric_time_ms,
            "start_time": self.start_time_ms,
            "elapsed_time_in_milliseconds": self.elapsed_time_ms,
            "episode": self.episode,
            "trial": self.trial,
            "phase": self.phase,
            "completion_percentage": self.completion_percentage,
            "episode_status": self.episode_status.label,
        }


@dataclass(frozen=True)
class EvaluationMetricsEntry:
    """One lap (trial) of an evaluation; in continuous evaluation, laps before the last are "In progress"."""

    completion_percentage: int
    metric_time_ms: int
    start_time_ms: int
    elapsed_time_ms: int
    """Includes penalty pauses: the simulation clock keeps running while the car waits."""
    episode_status: EpisodeStatus
    crash_count: int
    immobilized_count: int
    off_track_count: int
    reversed_count: int
    reset_count: int
    """Sum of the four counts when written by the SimApp."""
    trial: int
    """1-based number of the lap."""

    @classmethod
    def from_lap(
        cls,
        *,
        progress_pct: float,
        start_time_s: float,
        end_time_s: float,
        status: EpisodeStatus,
        trial: int,
        crash_count: int = 0,
        immobilized_count: int = 0,
        off_track_count: int = 0,
        reversed_count: int = 0,
    ) -> EvaluationMetricsEntry:
        """Apply the SimApp's conversions; reset_count is the sum of the four counts."""
        counts = (crash_count, immobilized_count, off_track_count, reversed_count)
        if any(count < 0 for count in counts):
            raise ValueError(f"reset counts must not be negative, got {counts}")
        return cls(
            completion_percentage=int(progress_pct),
            metric_time_ms=sim_time_to_ms(end_time_s),
            start_time_ms=sim_time_to_ms(start_time_s),
            elapsed_time_ms=sim_time_to_ms(end_time_s - start_time_s),
            episode_status=EpisodeStatus(status),
            crash_count=int(crash_count),
            immobilized_count=int(immobilized_count),
            off_track_count=int(off_track_count),
            reversed_count=int(reversed_count),
            reset_count=int(sum(counts)),
            trial=int(trial),
        )

    def to_dict(self) -> dict[str, int | str]:
        """DeepRacer's keys in DeepRacer's order."""
        return {
            "completion_percentage": self.completion_percentage,
            "metric_time": self.metric_time_ms,
            "start_time": self.start_time_ms,
            "elapsed_time_in_milliseconds": self.elapsed_time_ms,
            "episode_status": self.episode_status.label,
            "crash_count": self.crash_count,
            "immobilized_count": self.immobilized_count,
            "off_track_count": self.off_track_count,
            "reversed_count": self.reversed_count,
            "reset_count": self.reset_count,
            "trial": self.trial,
        }


class TrainingMetrics:
    """The entries of one worker's TrainingMetrics.json (worker i > 0 writes TrainingMetrics_<i>.json)."""

    def __init__(
        self,
        entries: Iterable[TrainingMetricsEntry] = (),
        *,
        version: float | None = TRAINING_METRICS_VERSION,
        best_model_metric: str | None = "progress",
    ) -> None:
        if best_model_metric is not None and best_model_metric not in BEST_MODEL_METRICS:
            raise ValueError(f"best_model_metric {best_model_metric!r}: allowed: {', '.join(BEST_MODEL_METRICS)}")
        self.version = version
        """None only for files read without a version key (it is then left out when writing)."""
        self.best_model_metric = best_model_metric
        self._entries: list[TrainingMetricsEntry] = list(entries)

    @property
    def entries(self) -> tuple[TrainingMetricsEntry, ...]:
        return tuple(self._entries)

    def append(self, entry: TrainingMetricsEntry) -> None:
        self._entries.append(entry)

    def __len__(self) -> int:
        return len(self._entries)

    def to_dict(self) -> dict[str, object]:
        data: dict[str, object] = {"metrics": [entry.to_dict() for entry in self._entries]}
        if self.version is not None:
            data["version"] = self.version
        if self.best_model_metric is not None:
            data["best_model_metric"] = self.best_model_metric
        return data

    def to_bytes(self) -> bytes:
        """The file body exactly as the SimApp uploads it."""
        return json.dumps(self.to_dict()).encode("utf-8")


class EvaluationMetrics:
    """The laps of one evaluation run (`{"metrics": [...]}`, no version key)."""

    def __init__(self, entries: Iterable[EvaluationMetricsEntry] = ()) -> None:
        self._entries: list[EvaluationMetricsEntry] = list(entries)

    @property
    def entries(self) -> tuple[EvaluationMetricsEntry, ...]:
        return tuple(self._entries)

    def append(self, entry: EvaluationMetricsEntry) -> None:
        self._entries.append(entry)

    def __len__(self) -> int:
        return len(self._entries)

    def to_dict(self) -> dict[str, object]:
        return {"metrics": [entry.to_dict() for entry in self._entries]}

    def to_bytes(self) -> bytes:
        return json.dumps(self.to_dict()).encode("utf-8")


def _load(path_or_bytes: str | PathLike[str] | bytes, source: str | None, default_name: str) -> tuple[object, str]:
    if isinstance(path_or_bytes, (bytes, bytearray)):
        raw = bytes(path_or_bytes)
        name = source or default_name
    else:
        with open(path_or_bytes, "rb") as handle:
            raw = handle.read()
        name = source or str(path_or_bytes)
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as error:
        raise MetricsError(f"{name}: not UTF-8 text (byte {error.start})") from None
    try:
        return json.loads(text), name
    except json.JSONDecodeError as error:
        raise MetricsError(f"{name}: invalid JSON at line {error.lineno}, column {error.colno}: {error.msg}") from None


def _entry_dicts(data: object, name: str) -> tuple[Mapping[str, object], list[Mapping[str, object]]]:
    """The top-level object and its `metrics` list, each entry checked to be an object."""
    if not isinstance(data, Mapping):
        raise MetricsError(f"{name}: expected a JSON object at the top level, got {type(data).__name__}")
    if "metrics" not in data:
        raise MetricsError(f"{name}: metrics: missing")
    entries = data["metrics"]
    if not isinstance(entries, list):
        raise MetricsError(f"{name}: metrics: expected a list, got {type(entries).__name__}")
    for index, entry in enumerate(entries):
        if not isinstance(entry, Mapping):
            raise MetricsError(f"{name}: metrics[{index}]: expected a JSON object, got {type(entry).__name__}")
    return data, entries


def _fields(entry: Mapping[str, object], keys: tuple[str, ...], where: str) -> dict[str, int | str]:
    """The entry's values with integer keys checked; unknown keys are ignored (the analysis tools ignore them too)."""
    values: dict[str, int | str] = {}
    for key in keys:
        if key not in entry:
            raise MetricsError(f"{where}: missing key {key!r}")
        value = entry[key]
        if key in ("phase", "episode_status"):
            if not isinstance(value, str):
                raise MetricsError(f"{where}.{key}: {value!r} is not a string")
        elif isinstance(value, bool) or not isinstance(value, int):
            raise MetricsError(f"{where}.{key}: {value!r} is not an integer")
        values[key] = value
    return values


def _status(label: object, where: str) -> EpisodeStatus:
    try:
        return EpisodeStatus.from_label(str(label))
    except ValueError as error:
        raise MetricsError(f"{where}.episode_status: {error}") from None


def read_training_metrics(path_or_bytes: str | PathLike[str] | bytes, source: str | None = None) -> TrainingMetrics:
    """Read TrainingMetrics.json; errors name the file and the entry, e.g. 'x.json: metrics[3].phase: ...'."""
    data, name = _load(path_or_bytes, source, "<TrainingMetrics bytes>")
    top, entry_dicts = _entry_dicts(data, name)
    version = top.get("version")
    if version is not None and (isinstance(version, bool) or not isinstance(version, (int, float))):
        raise MetricsError(f"{name}: version: {version!r} is not a number")
    best = top.get("best_model_metric")
    if best is not None and best not in BEST_MODEL_METRICS:
        raise MetricsError(f"{name}: best_model_metric: {best!r}; allowed: {', '.join(BEST_MODEL_METRICS)}")
    entries = []
    for index, entry in enumerate(entry_dicts):
        where = f"{name}: metrics[{index}]"
        values = _fields(entry, TRAINING_METRICS_KEYS, where)
        if values["phase"] not in PHASES:
            raise MetricsError(f"{where}.phase: {values['phase']!r}; allowed: {', '.join(PHASES)}")
        entries.append(
            TrainingMetricsEntry(
                reward_score=int(values["reward_score"]),
                metric_time_ms=int(values["metric_time"]),
                start_time_ms=int(values["start_time"]),
                elapsed_time_ms=int(values["elapsed_time_in_milliseconds"]),
                episode=int(values["episode"]),
                trial=int(values["trial"]),
                phase=str(values["phase"]),
                completion_percentage=int(values["completion_percentage"]),
                episode_status=_status(values["episode_status"], where),
            )
        )
    return TrainingMetrics(entries, version=None if version is None else float(version), best_model_metric=best)


def read_evaluation_metrics(path_or_bytes: str | PathLike[str] | bytes, source: str | None = None) -> EvaluationMetrics:
    """Read an EvaluationMetrics JSON; errors name the file and the entry, e.g. 'x.json: metrics[0].trial: ...'."""
    data, name = _load(path_or_bytes, source, "<EvaluationMetrics bytes>")
    entries = []
    for index, entry in enumerate(_entry_dicts(data, name)[1]):
        where = f"{name}: metrics[{index}]"
        values = _fields(entry, EVALUATION_METRICS_KEYS, where)
        for key in ("crash_count", "immobilized_count", "off_track_count", "reversed_count", "reset_count"):
            if int(values[key]) < 0:
                raise MetricsError(f"{where}.{key}: {values[key]} is negative")
        entries.append(
            EvaluationMetricsEntry(
                completion_percentage=int(values["completion_percentage"]),
                metric_time_ms=int(values["metric_time"]),
                start_time_ms=int(values["start_time"]),
                elapsed_time_ms=int(values["elapsed_time_in_milliseconds"]),
                episode_status=_status(values["episode_status"], where),
                crash_count=int(values["crash_count"]),
                immobilized_count=int(values["immobilized_count"]),
                off_track_count=int(values["off_track_count"]),
                reversed_count=int(values["reversed_count"]),
                reset_count=int(values["reset_count"]),
                trial=int(values["trial"]),
            )
        )
    return EvaluationMetrics(entries)
