"""Helpers for the evaluation-worker tests: a session driven by the scripted policy, on a local store."""

from __future__ import annotations

import datetime as dt
from pathlib import Path

from racer.evaluation_worker.config import DeepRacerRules, EvaluationConfig, SummitRules, VideoOptions
from racer.evaluation_worker.runner import EvaluationReport, EvaluationSession
from racer.shared.deepracer.model_metadata import ModelMetadata
from racer.shared.deepracer.simtrace import read_simtrace
from racer.shared.sim.objects.challenge import ChallengeConfig
from racer.shared.store import LocalStore, ObjectStore
from tests.evaluation.scripted import CONTINUOUS_METADATA, ScriptedPolicy
from tests.torch_threads import one_torch_thread  # noqa: F401 (an autouse fixture for this folder)

NO_VIDEO = VideoOptions(enabled=False)


def run_scripted(
    store_root: Path,
    *,
    mode: str = "deepracer",
    exits: dict[int, list[float]] | None = None,
    speed_mps: float = 2.0,
    deepracer: DeepRacerRules | None = None,
    summit: SummitRules | None = None,
    video: VideoOptions = NO_VIDEO,
    mcap: bool = False,
    track: str = "racer_oval",
    world: str = "base",
    reverse_dir: bool = False,
    out_dir: Path | None = None,
    now: dt.datetime | None = None,
    model_prefix: str = "scripted-model",
    model_metadata: ModelMetadata = CONTINUOUS_METADATA,
    store: ObjectStore | None = None,
    shortcut_m: float | None = None,
    challenge: ChallengeConfig | None = None,
) -> tuple[EvaluationReport, ScriptedPolicy]:
    policy = ScriptedPolicy(speed_mps, exits, shortcut_m=shortcut_m)
    config = EvaluationConfig(
        model_prefix=model_prefix,
        mode=mode,
        track=track,
        world=world,
        reverse_dir=reverse_dir,
        deepracer=deepracer or DeepRacerRules(),
        summit=summit or SummitRules(),
        video=video,
        mcap=mcap,
        challenge=challenge or ChallengeConfig(),
    )
    session = EvaluationSession(
        store or LocalStore(store_root), config, policy=policy, model_metadata=model_metadata, out_dir=out_dir, now=now
    )
    policy.attach(session.driver)
    return session.run(), policy


def simtrace_of(store_root: Path, report: EvaluationReport):
    return read_simtrace((store_root / report.keys["simtrace"]).read_bytes(), source=report.keys["simtrace"])
