"""How firmly the logs set the car's yaw inertia: hold it at each value, refit the other constants with the twin, and
report the loss in sample and held out (leave one file out). A flat profile would mean the fit's inertia is a loose
end; a steep one, that the logs themselves ask for it."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from research.tyre_fit.twin import (
    FIXED,
    LOFO_EVALUATIONS,
    NEUTRAL,
    CarConstants,
    SegmentBatch,
    fit,
    leave_one_file_out,
    loss,
    position_errors_m,
    simulate,
)

HELD = (*FIXED, "yaw_inertia_kgm2")
IN_SAMPLE_EVALUATIONS = 600
"""As many as `fit` spends on all files by default."""


def in_sample_loss(batch: SegmentBatch, yaw_inertia_kgm2: float, evaluations: int) -> float:
    """The loss on all segments with the inertia held and the rest fitted on them, from the shipped constants."""
    fitted = fit(batch, replace(CarConstants(), yaw_inertia_kgm2=yaw_inertia_kgm2), evaluations, fixed=HELD)
    return loss(batch, fitted)


def held_out_errors(batch: SegmentBatch, yaw_inertia_kgm2: float, evaluations: int) -> tuple[float, np.ndarray]:
    """Each file replayed with the rest fitted on the other files (from `NEUTRAL`, the inertia held): the loss
    averaged over segments, and every segment's position error after 1 s (m)."""
    start = replace(NEUTRAL, yaw_inertia_kgm2=yaw_inertia_kgm2)
    folds = leave_one_file_out(batch, evaluations, start=start, fixed=HELD)
    weighted_loss, errors = 0.0, []
    for source, fitted in folds.items():
        held_out = batch.sources == source
        segments = batch.subset(held_out)
        weighted_loss += loss(segments, fitted) * int(held_out.sum())
        xs, ys, _ = simulate(segments, fitted)
        errors.append(position_errors_m(segments, xs, ys, 1.0))
    return weighted_loss / len(batch.sources), np.concatenate(errors)


def inertia_profile(
    batch: SegmentBatch,
    values_kgm2: Sequence[float],
    held_out: bool = True,
    evaluations: int = IN_SAMPLE_EVALUATIONS,
    held_out_evaluations: int = LOFO_EVALUATIONS,
) -> list[dict]:
    """One row per held inertia: the in-sample loss and, with `held_out`, the held-out loss and median error."""
    rows = []
    for value in values_kgm2:
        row = {"yaw_inertia_kgm2": value, "loss_in_sample": round(in_sample_loss(batch, value, evaluations), 4)}
        if held_out:
            held_loss, errors = held_out_errors(batch, value, held_out_evaluations)
            row["loss_held_out"] = round(held_loss, 4)
            row["median_position_error_1s_cm_held_out"] = round(100 * float(np.median(errors)), 2)
        rows.append(row)
    return rows
