"""Grey-level statistics of camera frames and their distance: how the camera proxy compares racer's look with the
Gazebo frames, as a set (histogram, region means) and on paired frames of the same poses."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

UPPER_ROWS = slice(0, 40)
LOWER_ROWS = slice(60, 120)


@dataclass(frozen=True)
class FrameStats:
    """Grey-level statistics of a set of 160x120 frames."""

    histogram: np.ndarray
    lower_half_mean: float
    upper_third_mean: float


def frame_stats(gray_frames: np.ndarray) -> FrameStats:
    """(N, 120, 160) uint8 grey frames -> normalised histogram and region means."""
    histogram = np.bincount(gray_frames.ravel(), minlength=256).astype(np.float64)
    return FrameStats(
        histogram / histogram.sum(),
        float(gray_frames[:, LOWER_ROWS].mean()),
        float(gray_frames[:, UPPER_ROWS].mean()),
    )


def histogram_emd(a: np.ndarray, b: np.ndarray) -> float:
    """Earth-mover distance between two normalised 256-bin histograms, in grey levels."""
    return float(np.abs(np.cumsum(a) - np.cumsum(b)).sum())


PAIRED_BANDS = ((0, 40), (40, 80), (80, 120))
"""Image rows compared on the pairs: above the horizon (walls), the far field and road, the near road."""


def paired_grey_stats(ours_gray: np.ndarray, gazebo_gray: np.ndarray) -> dict:
    """racer's grey frames against the Gazebo frames of the same poses (the same views, so only the look differs):
    histogram distance of the two sets, mean absolute difference per pixel, mean grey per band (racer, Gazebo)."""
    if ours_gray.shape != gazebo_gray.shape:
        raise ValueError(f"{len(ours_gray)} racer frames for {len(gazebo_gray)} Gazebo frames")
    return {
        "histogram_emd": round(histogram_emd(frame_stats(ours_gray).histogram, frame_stats(gazebo_gray).histogram), 2),
        "mean_abs_grey_difference": round(float(np.abs(ours_gray.astype(int) - gazebo_gray.astype(int)).mean()), 1),
        "band_means_racer_vs_gazebo": {
            f"rows {top}-{bottom}": [
                round(float(ours_gray[:, top:bottom].mean()), 1),
                round(float(gazebo_gray[:, top:bottom].mean()), 1),
            ]
            for top, bottom in PAIRED_BANDS
        },
    }
