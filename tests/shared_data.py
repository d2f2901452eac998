"""Where the real DeepRacer files live: ../shared/deepracer-data beside the repository, read in place, never copied."""

from __future__ import annotations

from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[1]
SHARED_DATA = REPO_ROOT.parent / "shared" / "deepracer-data"
"""Real DeepRacer files (routes, simtraces, metrics, configs, reward functions, checkpoints, frames, worlds)."""
