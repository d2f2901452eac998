"""One evaluation from start to finish: pick the checkpoint, build the env and recorders, run the mode, write files.

    session = EvaluationSession(store, EvaluationConfig(model_prefix="my-model", mode="race"))
    report = session.run(log=print)      # files are in the store under my-model/evaluation-<ts>/ ...

`policy=` replaces the stored network (tests drive with a scripted policy; it may read `session.driver`).
Files are produced in a local folder first (ffmpeg and MCAP write files), then copied to the store; `out_dir=` keeps
that folder (same relative layout as under the model prefix), otherwise it is a temporary folder removed at the end.
"""

from __future__ import annotations

import datetime as dt
import json
import shutil
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from racer.evaluation_worker.config import EvaluationConfig
from racer.evaluation_worker.deepracer_eval import run_deepracer_evaluation
from racer.evaluation_worker.driver import EvaluationDriver, ProgressLog, StepObserver, no_log
from racer.evaluation_worker.laps import LapResult, describe_lap
from racer.evaluation_worker.mcap_recording import McapRecorder
from racer.evaluation_worker.outputs import (
    SimtraceRecorder,
    choose_run_name,
    evaluation_metrics,
    evaluation_params,
    format_table,
    summary_dict,
)
from racer.evaluation_worker.summit_rule import SummitResult, run_summit
from racer.evaluation_worker.video import VIEWS, VideoRecorder
from racer.shared.deepracer.metrics import EvaluationMetrics
from racer.shared.deepracer.model_metadata import ModelMetadata, ModelMetadataError, parse_model_metadata
from racer.shared.deepracer.training_params import training_params_to_yaml
from racer.shared.model_layout import EvaluationLayout, ModelLayout
from racer.shared.policy.checkpoints import CheckpointStore
from racer.shared.policy.manifest import CheckpointError
from racer.shared.policy.protocol import Policy
from racer.shared.policy.torch_threads import one_torch_thread_if_loaded
from racer.shared.run_settings import env_config
from racer.shared.sim.config import EnvConfig
from racer.shared.sim.env import DeepRacerEnv
from racer.shared.sim.objects.track_objects import TrackObjects
from racer.shared.store import ObjectNotFoundError, ObjectStore


@dataclass(frozen=True)
class EvaluationReport:
    layout: EvaluationLayout
    checkpoint: str | None
    """The checkpoint evaluated (None when a policy object was given)."""
    laps: tuple[LapResult, ...]
    summit: SummitResult | None
    metrics: EvaluationMetrics
    summary: dict[str, Any]
    table: str
    keys: dict[str, str]
    """What was written: name (`metrics`, `simtrace`, `summary`, `mcap`, `camera-...`) -> store key."""
    local_dir: Path | None
    """The kept local copy (`out_dir`), if any."""
    video_frames: dict[str, int]
    mcap_messages: dict[str, int]


def read_model_metadata(
    store: ObjectStore, checkpoints: CheckpointStore, model_prefix: str, checkpoint: str
) -> ModelMetadata:
    """`<prefix>/model/model_metadata.json`, or the copy in the checkpoint's manifest when the file is absent."""
    key = ModelLayout(model_prefix).model_metadata
    source = f"{store.describe()}/{key}"
    try:
        raw = store.get_bytes(key)
    except ObjectNotFoundError:
        info = checkpoints.read_info(checkpoint)
        if info.model_metadata is None:
            raise CheckpointError(
                f"{source} is missing and checkpoint {checkpoint} does not record its model_metadata"
            ) from None
        return parse_model_metadata(info.model_metadata, source=f"{source} (from the manifest of {checkpoint})")
    try:
        data = json.loads(raw)
    except json.JSONDecodeError as error:
        raise ModelMetadataError(f"{source}: not valid JSON: {error}") from error
    return parse_model_metadata(data, source=source)


def _check_policy_inputs(policy: Policy, env: DeepRacerEnv, checkpoint: str | None) -> None:
    if hasattr(policy, "input_names"):  # a torch network (ActorCritic, SACNetworks) given in-process
        needed, given = set(policy.input_names), set(env.observation_space.spaces)
        if not needed <= given:
            raise CheckpointError(
                f"checkpoint {checkpoint} needs inputs {sorted(needed)} but the model_metadata sensors give {sorted(given)}"
            )


class EvaluationSession:
    def __init__(
        self,
        store: ObjectStore,
        config: EvaluationConfig,
        *,
        policy: Policy | None = None,
        model_metadata: ModelMetadata | None = None,
        out_dir: Path | None = None,
        now: dt.datetime | None = None,
        track_objects: TrackObjects | None = None,
    ) -> None:
        """`track_objects`: the other cars of a multi-car race (`multi_car_session`), in place of `challenge`'s."""
        self.store = store
        self.config = config
        prefix = config.model_prefix.strip("/")
        self.checkpoint: str | None = None
        if policy is None:
            checkpoints = CheckpointStore(store, prefix)
            self.checkpoint = checkpoints.select(config.checkpoint)
            policy = checkpoints.load_inference_policy(self.checkpoint)  # the exported ONNX model, as on a car
            if model_metadata is None:
                model_metadata = read_model_metadata(store, checkpoints, prefix, self.checkpoint)
        elif model_metadata is None:
            raise ValueError("a policy object needs its model_metadata")
        self.policy = policy
        self.model_metadata = model_metadata
        self.layout = EvaluationLayout(prefix, choose_run_name(store, prefix, now or dt.datetime.now(dt.UTC)))
        self.env = DeepRacerEnv(
            self._env_config(),
            render_mode="rgb_array" if (config.video.enabled or config.mcap) else None,
            track_objects=track_objects,
        )
        self._keep_dir = out_dir is not None
        self.simtrace = SimtraceRecorder()
        observers: list[StepObserver] = [self.simtrace]
        self.video: VideoRecorder | None = None
        self.mcap: McapRecorder | None = None
        workdir: Path | None = None
        ready = False
        try:
            _check_policy_inputs(policy, self.env, self.checkpoint)
            workdir = Path(out_dir) if out_dir is not None else Path(tempfile.mkdtemp(prefix="racer-eval-"))
            workdir.mkdir(parents=True, exist_ok=True)
            self.workdir = workdir
            if config.video.enabled:
                self.video = VideoRecorder(self.env, self.workdir / self.layout.run_name, config.video)
                observers.append(self.video)
            if config.mcap:
                self.mcap = McapRecorder(self.env, self.workdir / self.layout.relative("mcap"), self._header())
                observers.append(self.mcap)
            ready = True
        finally:
            if not ready:  # a bad setting or a failing encoder: release what was opened, leave nothing behind
                for observer in observers:
                    observer.close()
                self.env.close()
                if workdir is not None and not self._keep_dir:
                    shutil.rmtree(workdir, ignore_errors=True)
        self.driver = EvaluationDriver(self.env, policy, observers, seed=config.seed)

    def _env_config(self) -> EnvConfig:
        return env_config(*self.config.run_settings(self.model_metadata))

    def _header(self) -> dict[str, Any]:
        config = self.config
        return {
            "model_prefix": self.layout.model_prefix,
            "checkpoint": self.checkpoint,
            "checkpoint_requested": config.checkpoint if self.checkpoint is not None else None,
            "evaluation": self.layout.run_name,
            "track": str(config.track),
            "track_length_m": round(self.env.base_track.length_m, 6),
            "world": config.world,
            "reverse_dir": config.reverse_dir,
            "generation": config.generation,
            "car_profile": config.car_profile,
            "action_space_type": "continuous" if self.model_metadata.is_continuous else "discrete",
            "sensors": sorted(self.env.observation_space.spaces),
        }

    def run(self, log: ProgressLog = no_log) -> EvaluationReport:
        config = self.config
        one_torch_thread_if_loaded()
        log(
            f"evaluating {self.layout.model_prefix} checkpoint {self.checkpoint or '(given policy)'}: mode {config.mode}, "
            f"track {config.track} ({self.env.base_track.length_m:.2f} m){' reversed' if config.reverse_dir else ''}, "
            f"world {config.world} -> {self.layout.key(self.layout.run_name)}"
        )
        started = time.perf_counter()
        summit: SummitResult | None = None
        finished: list[LapResult] = []
        metrics_key = self.layout.key(self.layout.relative("metrics"))

        def on_lap(lap: LapResult) -> None:
            # Like the SimApp, the metrics file is rewritten after every lap, so a long evaluation can be watched.
            finished.append(lap)
            log(describe_lap(lap))
            self.store.put_bytes(metrics_key, evaluation_metrics(finished).to_bytes())

        try:
            if config.mode == "race":
                summit = run_summit(self.driver, config.summit, on_lap)
                laps = summit.laps
            else:
                laps = tuple(run_deepracer_evaluation(self.driver, config.deepracer, on_lap))
        finally:
            self.driver.close()
            self.env.close()
        return self.finish(laps, summit, time.perf_counter() - started)

    def finish(
        self,
        laps: tuple[LapResult, ...],
        summit: SummitResult | None,
        wall_s: float,
        extra: dict[str, Any] | None = None,
    ) -> EvaluationReport:
        """Write the files of a run whose steps the driver has taken (and closed), and drop the work folder.
        `extra`: more summary keys (a multi-car race's)."""
        try:
            return self._write(laps, summit, wall_s, extra or {})
        finally:
            if not self._keep_dir:
                shutil.rmtree(self.workdir, ignore_errors=True)

    def _write(
        self, laps: tuple[LapResult, ...], summit: SummitResult | None, wall_s: float, extra: dict[str, Any]
    ) -> EvaluationReport:
        config, layout = self.config, self.layout
        steps = self.driver.steps_total
        files: dict[str, str] = {
            "metrics": layout.relative("metrics"),
            "simtrace": layout.relative("simtrace"),
            "summary": layout.relative("summary"),
            "params": layout.relative("params"),
        }
        if self.video is not None:
            files.update({view: layout.video(view) for view in VIEWS})
        if self.mcap is not None:
            files["mcap"] = layout.relative("mcap")
        sim_s = (laps[-1].end_time_s - laps[0].start_time_s) if laps else 0.0
        video_frames = self.video.frame_counts if self.video is not None else {}
        recorder_s = {name: round(seconds, 3) for name, seconds in self.driver.observer_seconds.items()}
        timings = {
            "wall_time_s": round(wall_s, 3),
            "steps": steps,
            "steps_per_s": round(steps / wall_s, 2) if wall_s > 0 else None,
            "sim_time_s": round(sim_s, 3),
            "real_time_factor": round(sim_s / wall_s, 3) if wall_s > 0 else None,
            "recorder_wall_s": recorder_s,
            "video_ms_per_frame": round(1000.0 * recorder_s.get("VideoRecorder", 0.0) / steps, 2)
            if video_frames and steps
            else None,
            "video_frames": video_frames,
        }
        rules = config.summit if config.mode == "race" else config.deepracer
        metrics = evaluation_metrics(laps)
        summary = summary_dict(
            mode=config.mode,
            header=self._header(),
            rules=rules,
            laps=laps,
            summit=summit,
            track_length_m=self.env.base_track.length_m,
            timings=timings,
            files={name: layout.key(relative) for name, relative in files.items()},
        )
        summary.update(extra)
        contents = {
            files["metrics"]: metrics.to_bytes(),
            files["simtrace"]: self.simtrace.writer.to_bytes(),
            files["summary"]: (json.dumps(summary, indent=2) + "\n").encode(),
            files["params"]: training_params_to_yaml(evaluation_params(config, layout, self.checkpoint)).encode(),
        }
        for relative, data in contents.items():
            path = self.workdir / relative
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_bytes(data)
        for relative in files.values():
            self.store.put_bytes(layout.key(relative), (self.workdir / relative).read_bytes())
        return EvaluationReport(
            layout=layout,
            checkpoint=self.checkpoint,
            laps=laps,
            summit=summit,
            metrics=metrics,
            summary=summary,
            table=format_table(laps, self.env.base_track.length_m),
            keys={name: layout.key(relative) for name, relative in files.items()},
            local_dir=self.workdir if self._keep_dir else None,
            video_frames=video_frames,
            mcap_messages=dict(self.mcap.message_counts) if self.mcap is not None else {},
        )
