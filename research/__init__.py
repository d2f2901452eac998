"""Studies that answered a question about racer once, kept so their answers can be reproduced.

Not part of the product: the wheel does not install this folder and nothing under racer/, shared/, trainer/,
rollout_worker/, evaluation_worker/ or tracks/ imports it (tests/foundation/test_no_research_imports.py). A study
runs from the repository root with the project's environment, `python -m research.<study> ...`, and may import
racer. README.md lists the studies.
"""

from __future__ import annotations

from pathlib import Path

DEEPRACER_DATA = Path(__file__).resolve().parents[1].parent / "shared" / "deepracer-data"
"""The DeepRacer test data beside the checkout (real simtraces, routes, the Gazebo frames, real models): every
study's default `--data`."""
