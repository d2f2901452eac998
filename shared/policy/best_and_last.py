"""`model/deepracer_checkpoints.json`: the best and the last evaluated checkpoint, and DeepRacer's rule for them."""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass

from racer.shared.model_layout import CheckpointName


@dataclass(frozen=True)
class CheckpointRecord:
    """One entry of deepracer_checkpoints.json."""

    name: str
    avg_eval_metric: float | None
    time_stamp: float | None

    def to_dict(self) -> dict:
        return {"name": self.name, "avg_eval_metric": self.avg_eval_metric, "time_stamp": self.time_stamp}


@dataclass(frozen=True)
class BestAndLast:
    best: CheckpointRecord | None
    last: CheckpointRecord | None


def _lenient_record(data: object) -> CheckpointRecord | None:
    if not isinstance(data, Mapping) or "name" not in data:
        return None
    metric = data.get("avg_eval_metric", data.get("avg_comp_pct"))  # older DRfC files use avg_comp_pct
    stamp = data.get("time_stamp")
    return CheckpointRecord(
        str(data["name"]), None if metric is None else float(metric), None if stamp is None else float(stamp)
    )


def read_best_and_last(data: bytes) -> BestAndLast | None:
    """Lenient: what racer and DeepRacer-for-Cloud wrote (entries without a name count as absent); None when the
    document is not a JSON object."""
    document = json.loads(data)
    if not isinstance(document, Mapping):
        return None
    return BestAndLast(
        best=_lenient_record(document.get("best_checkpoint")), last=_lenient_record(document.get("last_checkpoint"))
    )


def best_and_last_to_bytes(best: CheckpointRecord | None, last: CheckpointRecord | None) -> bytes:
    data = {}
    if best is not None:
        data["best_checkpoint"] = best.to_dict()
    if last is not None:
        data["last_checkpoint"] = last.to_dict()
    return json.dumps(data).encode()


def after_evaluation(current: BestAndLast | None, record: CheckpointRecord, higher_is_better: bool) -> BestAndLast:
    """DeepRacer's rule (TrainingMetrics.update): `record` becomes the last checkpoint, and the best one when its
    metric is at least as good as the best so far (ties go to the newer checkpoint). Progress and reward are
    higher-is-better; lap time is lower-is-better."""
    best = current.best if current is not None else None
    if (
        best is None
        or best.avg_eval_metric is None
        or (higher_is_better and record.avg_eval_metric >= best.avg_eval_metric)
        or (not higher_is_better and record.avg_eval_metric <= best.avg_eval_metric)
    ):
        best = record
    return BestAndLast(best=best, last=record)


@dataclass(frozen=True)
class BestAndLastNames:
    best: str
    last: str


def parse_best_and_last_names(data: bytes) -> BestAndLastNames:
    """Strict, for model validation: both entries must name a checkpoint; ValueError naming the field."""
    try:
        document = json.loads(data)
    except (UnicodeDecodeError, json.JSONDecodeError) as error:
        raise ValueError(f"is not valid JSON ({error})") from None
    if not isinstance(document, dict):
        raise ValueError("must be a JSON object with best_checkpoint and last_checkpoint")
    names: dict[str, str] = {}
    for field_name in ("best_checkpoint", "last_checkpoint"):
        entry = document.get(field_name)
        if not isinstance(entry, dict) or not isinstance(entry.get("name"), str) or not entry["name"].strip():
            raise ValueError(f"{field_name}.name is missing or not a string")
        names[field_name] = entry["name"].strip()
    return BestAndLastNames(best=names["best_checkpoint"], last=names["last_checkpoint"])


def names_to_bytes(
    best: CheckpointName, last: CheckpointName, best_metric: float | None = None, last_metric: float | None = None
) -> bytes:
    """A deepracer_checkpoints.json naming `best` and `last` (metric fields only when known), for exported models."""

    def entry(name: CheckpointName, metric: float | None) -> dict[str, object]:
        return {"name": name.name} if metric is None else {"name": name.name, "avg_eval_metric": metric}

    return json.dumps(
        {"best_checkpoint": entry(best, best_metric), "last_checkpoint": entry(last, last_metric)}
    ).encode()
