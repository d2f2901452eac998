"""Continuous action spaces (clipped PPO or SAC): how the commanded steering and speed are distributed, and how that
changes over training. A discrete model picks from a handful of actions (action_usage shows those); a continuous one
can collapse onto the edges of its ranges or stay timid in the middle, which only a distribution shows.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

DPI = 110
PHASES_SHOWN = 3
"""Training is cut into this many equal spans of iterations (early, middle, late), one histogram line each."""


def is_continuous(steps: pd.DataFrame) -> bool:
    """Discrete simtraces log the action index; continuous ones log "[<steer> <speed>]"."""
    return bool(len(steps)) and pd.to_numeric(steps["action"], errors="coerce").isna().any()


def action_distributions(steps: pd.DataFrame, path: Path) -> Path:
    """Steering and speed histograms for early / middle / late training, and steering against speed overall."""
    driving = steps[steps["episode_status"] != "prepare"]
    iterations = np.sort(driving["iteration"].unique())
    spans = [span for span in np.array_split(iterations, min(PHASES_SHOWN, len(iterations))) if len(span)]
    figure = Figure(figsize=(15, 4.5), layout="constrained")
    steer_ax, speed_ax, joint_ax = figure.subplots(1, 3, width_ratios=[1, 1, 1.1])
    steer_bins = np.linspace(driving["steer"].min() - 1e-6, driving["steer"].max() + 1e-6, 31)
    speed_bins = np.linspace(driving["throttle"].min() - 1e-6, driving["throttle"].max() + 1e-6, 31)
    for number, span in enumerate(spans):
        chosen = driving[driving["iteration"].isin(span)]
        label = f"iterations {span[0]}-{span[-1]} ({len(chosen)} steps)"
        steer_ax.hist(
            chosen["steer"],
            bins=steer_bins,
            density=True,
            histtype="step",
            linewidth=1.6,
            color=f"C{number}",
            label=label,
        )
        speed_ax.hist(
            chosen["throttle"],
            bins=speed_bins,
            density=True,
            histtype="step",
            linewidth=1.6,
            color=f"C{number}",
            label=label,
        )
    steer_ax.set_xlabel("steering (deg, + = left)")
    speed_ax.set_xlabel("speed (m/s)")
    for ax in (steer_ax, speed_ax):
        ax.set_ylabel("density")
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
    steer_ax.set_title("steering over training")
    speed_ax.set_title("speed over training")
    cells = joint_ax.hist2d(driving["steer"], driving["throttle"], bins=[steer_bins, speed_bins], cmap="Blues", cmin=1)[
        3
    ]
    figure.colorbar(cells, ax=joint_ax, label="steps")
    joint_ax.set_xlabel("steering (deg)")
    joint_ax.set_ylabel("speed (m/s)")
    joint_ax.set_title(f"steering vs speed, all {len(driving)} training steps")
    figure.savefig(path, dpi=DPI, bbox_inches="tight")
    return path
