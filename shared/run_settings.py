"""Run settings: the one way from the command line, workers.json and training_params.yaml to an `EnvConfig`.

A setting of a training run travels, and changes form, only here and in racer.shared.worker_settings:

    racer train / racer trainer options -> `RunOptions` (`trainer_args` writes them for the trainer process)
    -> `load_worker_settings` (defaults, options, custom_files/workers.json) -> one `WorkerSettings` per worker
    -> training_params[_<i>].yaml (`WorkerSettings.to_training_params`, written by the trainer)
    -> `WorkerSettings.from_training_params` (the rollout worker) -> `env_config` -> `EnvConfig`.

An evaluation job builds its `WorkerSettings` from its own options (racer.evaluation_worker.config) and calls the same
`env_config`. Each WorkerSettings field names its training_params key and EnvConfig field (`setting()`), so a new
setting is one field there; `JobSettings` holds what the job (training or evaluation) sets itself, and
`NOT_FROM_SETTINGS` the EnvConfig fields no run setting reaches (tests/foundation/test_run_settings.py holds the three to
the EnvConfig fields).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, fields
from pathlib import Path

from racer.shared.deepracer.model_metadata import ModelMetadata
from racer.shared.sim.config import DEFAULT_MODEL_METADATA, DEFAULT_TRACK, EnvConfig
from racer.shared.sim.generations.catalog import DEFAULT_GENERATION
from racer.shared.sim.objects.challenge import param_text
from racer.shared.sim.scene.worlds import WORLD_NAMES
from racer.shared.user_errors import RunConfigError
from racer.shared.worker_settings import SETTING, WorkerSettings

__all__ = [
    "NOT_FROM_SETTINGS",
    "JobSettings",
    "RunOptions",
    "env_config",
    "load_worker_settings",
    "settings_fields",
]

NOT_FROM_SETTINGS: tuple[str, ...] = (
    "tracks_dir",
    "immobilized_steps",
    "immobilized_distance_m",
    "max_steps",
    "physics_substeps",
    "image_width_px",
    "image_height_px",
    "render_full_resolution",
    "look",
)
"""EnvConfig fields no run setting sets: the simulator's own constants (DeepRacer's camera size, the immobilized
rule, physics substeps) and what benchmarks and tests choose (a perturbed look). A run's env has their defaults (the
look is the generation's)."""


@dataclass(frozen=True)
class JobSettings:
    """What the job sets beside the worker's settings: the model it drives and the job's reset rules."""

    model_metadata: ModelMetadata = DEFAULT_MODEL_METADATA
    reward_function_path: Path | None = None
    """The run's reward file (training); None: DeepRacer's default evaluation reward (evaluation)."""
    immobilized_penalty_s: float = 0.0
    reverse_penalty_s: float | None = None
    """None: the off-track penalty, as the SimApp."""
    reset_position: str = "deepracer"
    """`deepracer` or `where_it_left` (the summit rule's marshal); `EnvConfig.reset_position`."""


def settings_fields() -> dict[str, str]:
    """{EnvConfig field: the WorkerSettings field that sets it}."""
    mapped = {}
    for item in fields(WorkerSettings):
        env_field = item.metadata[SETTING].env_field(item.name)
        if env_field is not None:
            mapped[env_field] = item.name
    return mapped


def env_config(settings: WorkerSettings, job: JobSettings) -> EnvConfig:
    """The env of a rollout or evaluation worker: its settings and the job's, every other field at its default."""
    values = {}
    for item in fields(WorkerSettings):
        spec = item.metadata[SETTING]
        env_field = spec.env_field(item.name)
        if env_field is None:
            continue
        value = getattr(settings, item.name)
        values[env_field] = value if spec.to_env is None else spec.to_env(value)
    values.update({item.name: getattr(job, item.name) for item in fields(JobSettings)})
    return EnvConfig(**values)


@dataclass(frozen=True)
class RunOptions:
    """The command line's settings for every worker of a run (`racer train`, `racer trainer`); workers.json may
    change them per worker. The launcher's plan, the trainer's options and the preflight all carry this one value."""

    num_workers: int
    track: str = DEFAULT_TRACK
    worlds: tuple[str, ...] = WORLD_NAMES
    """Given to the workers in turn."""
    domain_randomization: bool = False
    car_randomization: bool = False
    car_profile: str = ""
    """A car profile instead of the generation's car ("" = the generation's)."""
    dynamics_randomization: bool = False
    generation: str = DEFAULT_GENERATION
    """RACER_GENERATION: the DeepRacer simulator the workers stand in for (look and car)."""
    challenge_params: tuple[tuple[str, str], ...] = ()
    """RACE_TYPE and the obstacle / bot-car training_params keys (`--race-type`, `--race-param`)."""
    overlap: bool = False
    """`--overlap`: the workers play iteration k+1 with checkpoint k while the trainer updates (the trainer queues
    it early and announces which checkpoint plays it); False: DeepRacer's strict alternation."""

    def trainer_args(self) -> list[str]:
        """The same settings as `racer trainer` options (how `racer train` hands them to its trainer process)."""
        return [
            "--workers",
            str(self.num_workers),
            "--track",
            self.track,
            "--worlds",
            ",".join(self.worlds),
            "--domain-randomization",
            str(self.domain_randomization),
            "--car-randomization",
            str(self.car_randomization),
            "--car-profile",
            self.car_profile,
            "--dynamics-randomization",
            str(self.dynamics_randomization),
            "--generation",
            self.generation,
            *challenge_option_args(self.challenge_params),
            *(["--overlap"] if self.overlap else []),
        ]


def load_worker_settings(custom_files: Path, options: RunOptions) -> list[WorkerSettings]:
    """Defaults (world i to worker i, one track) and the options, then the optional custom_files/workers.json.

    workers.json holds DeepRacer training_params keys applied to every worker, and optionally
    `"workers": [{...}, {...}]` with per-worker overrides (like DeepRacer-for-Cloud's worker-N.env). The options'
    challenge keys (RACE_TYPE, obstacles, bot cars), generation, car profile and randomization flags apply to every
    worker under workers.json.
    """
    try:
        settings = [  # worker i gets world i, cycling through the worlds, on the same track
            WorkerSettings(
                world=options.worlds[i % len(options.worlds)],
                track=options.track,
                domain_randomization=options.domain_randomization,
                car_randomization=options.car_randomization,
                car_profile=options.car_profile,
                dynamics_randomization=options.dynamics_randomization,
                generation=options.generation,
            )
            for i in range(options.num_workers)
        ]
    except ValueError as error:
        raise RunConfigError(f"racer train options (--generation, --car-profile): {error}") from error
    if options.challenge_params:
        source = "racer train options (--race-type / --race-param)"
        try:
            settings = [
                WorkerSettings.from_training_params(
                    {**w.to_training_params("", options.num_workers), **dict(options.challenge_params)}, source
                )
                for w in settings
            ]
        except ValueError as error:
            raise RunConfigError(str(error)) from error
    path = custom_files / "workers.json"
    if not path.is_file():
        return settings
    try:
        data = json.loads(path.read_text())
    except json.JSONDecodeError as error:
        raise RunConfigError(f"{path}: line {error.lineno} column {error.colno}: {error.msg}") from error
    if not isinstance(data, dict):
        raise RunConfigError(f"{path}: expected a JSON object of training_params keys")
    per_worker = data.pop("workers", [])
    if not isinstance(per_worker, list):
        raise RunConfigError(f"{path}: workers: expected a list with one object per worker")
    result = []
    for worker_id, base in enumerate(settings):
        params = {k: param_text(v) for k, v in base.to_training_params("", options.num_workers).items()}
        params.update({k: param_text(v) for k, v in data.items()})
        if worker_id < len(per_worker):
            params.update({k: param_text(v) for k, v in per_worker[worker_id].items()})
        try:
            result.append(WorkerSettings.from_training_params(params, source=f"{path} (worker {worker_id})"))
        except ValueError as error:
            raise RunConfigError(str(error)) from error
    return result


def challenge_option_args(pairs: tuple[tuple[str, str], ...]) -> list[str]:
    """The same options as command-line arguments for a child process (`racer train` -> `racer trainer`)."""
    args: list[str] = []
    for key, value in pairs:
        args += ["--race-type", value] if key == "RACE_TYPE" else ["--race-param", f"{key}={value}"]
    return args
