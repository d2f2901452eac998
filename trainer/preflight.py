"""Preflight: every check a training run can make before any process or server starts.

`racer train`, `racer trainer` (and so the compose trainer service) call `preflight()` first. A model a user brings
either passes, or is refused here with one message naming the file, the field, the problem and the fix -- never
later, from inside a running trainer, after Redis and the workers were started. It runs once per run: `racer train`
runs it before it starts anything and passes `--preflight-passed` to its trainer, which then reads the files with
`read_checked_files`; `racer trainer` alone runs it before it connects and hands the report to the trainer.

Checks, in the order a user would fix them:
1. the three custom files exist;
2. model_metadata.json and hyperparameters.json parse (their own modules name file, field and allowed values);
3. the combination is one racer trains (`_check_combination`: what DeepRacer itself refuses, with the reason);
4. the reward function imports and defines `reward_function(params)`, and (after the tracks load) a short
   `racer reward test` over each worker's track and race type: a reward that raises or returns no usable number on
   params DeepRacer produces is refused;
5. workers.json parses (race types racer does not simulate yet -- obstacles, bot cars -- are refused by name,
   racer.shared.worker_settings), and every worker's track loads;
6. a clone source (`--pretrained-prefix`) in a local store has the same algorithm, action space and network;
7. your own network (network.json, when model_metadata.json names it) parses, embeds every sensor, and is not too
   large: refused above racer.shared.policy.network_size's parameter and one-core forward-time limits;
8. preset.json, when there is one, parses for the model's training algorithm (racer.trainer.preset).
Notes that do not stop training (keys the chosen algorithm ignores, idle workers) come back as warnings.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

from racer.shared.deepracer.hyperparameters import Hyperparameters, load_hyperparameters
from racer.shared.deepracer.model_metadata import (
    NEURAL_NETWORKS,
    ModelMetadata,
    load_model_metadata,
    parse_model_metadata,
)
from racer.shared.model_layout import ModelLayout
from racer.shared.policy.network_file import (
    NETWORK_FILE,
    NetworkFile,
    NetworkFileError,
    network_difference,
    network_for_metadata,
    parse_network_file,
)
from racer.shared.policy.network_size import network_size_findings
from racer.shared.run_settings import RunOptions, load_worker_settings
from racer.shared.sim.reward.function import load_reward_function
from racer.shared.sim.tracks.track import Track, TrackError
from racer.shared.store import ObjectNotFoundError, ObjectStore
from racer.shared.user_errors import CloneError, RunConfigError, UnsupportedConfigurationError
from racer.shared.worker_settings import WorkerSettings
from racer.trainer.preset import Preset, PresetError, load_preset

__all__ = [
    "PreflightReport",
    "UnsupportedConfigurationError",
    "check_clone_source",
    "load_worker_settings",
    "preflight",
    "read_checked_files",
]

CUSTOM_FILES = ("model_metadata.json", "hyperparameters.json", "reward_function.py")
PPO_EXPLORATION_TYPES = ("categorical", "e-greedy")
"""What DeepRacer's clipped-PPO agent accepts; anything else ends its job with 'Unknown exploration_type'."""
SAC_IGNORED_KEYS = ("beta_entropy", "num_epochs", "exploration_type", "e_greedy_value", "epsilon_steps")
"""Keys DeepRacer's SAC agent does not read (users' SAC files still carry some of them)."""


def _refuse(source: str, field: str, problem: str, fix: str) -> UnsupportedConfigurationError:
    return UnsupportedConfigurationError(f"{source}: {field}: {problem}; fix: {fix}")


@dataclass(frozen=True)
class PreflightReport:
    model_metadata: ModelMetadata
    hyperparameters: Hyperparameters
    workers: tuple[WorkerSettings, ...]
    warnings: tuple[str, ...]
    network: NetworkFile | None = None
    """network.json when model_metadata.json names it."""
    preset: Preset | None = None
    """preset.json, when the custom files have one."""


def _check_files_present(folder: Path) -> None:
    missing = [name for name in CUSTOM_FILES if not (folder / name).is_file()]
    if missing:
        raise RunConfigError(
            f"{folder}: missing {', '.join(missing)}; fix: put the file(s) in the custom files "
            f"folder (examples in custom_files/ of this repository)"
        )


def _check_combination(
    metadata: ModelMetadata,
    hyperparameters: Hyperparameters,
    metadata_path: Path,
    hyperparameters_path: Path,
    given_keys: set[str],
) -> list[str]:
    """Refuse what cannot train; return notes about settings the algorithm ignores."""
    warnings: list[str] = []
    if metadata.training_algorithm == "clipped_ppo":
        if "exploration_type" in given_keys and hyperparameters.exploration_type not in PPO_EXPLORATION_TYPES:
            raise _refuse(
                str(hyperparameters_path),
                "exploration_type",
                f"{hyperparameters.exploration_type!r} is for SAC; DeepRacer's clipped PPO stops with "
                f"'Unknown exploration_type' ({metadata_path} has training_algorithm clipped_ppo)",
                "set exploration_type to 'categorical' (or 'e-greedy' for a discrete action space), "
                "or training_algorithm to 'sac' with a continuous action space",
            )
        if metadata.is_continuous and hyperparameters.exploration_type == "e-greedy":
            warnings.append(
                f"{hyperparameters_path}: exploration_type: 'e-greedy' has no effect on a continuous "
                f"action space; the policy samples its Gaussian (as DeepRacer does)"
            )
    elif metadata.training_algorithm == "sac":
        ignored = sorted(key for key in SAC_IGNORED_KEYS if key in given_keys)
        if ignored:
            warnings.append(
                f"{hyperparameters_path}: {', '.join(ignored)}: not used by SAC (DeepRacer ignores them too)"
            )
    return warnings


def _given_keys(path: Path) -> set[str]:
    data = json.loads(path.read_text(encoding="utf-8-sig"))  # already parsed once: cannot fail here
    return set(data) if isinstance(data, dict) else set()


def _check_reward_over_track(path: Path, workers: list[WorkerSettings], metadata: ModelMetadata) -> list[str]:
    """A short `racer reward test`: the reward is called over worker 0's track and race type (and each other
    track/race type the workers use); one that raises or returns no usable number is refused before anything
    starts. Slow calls and what DeepRacer on AWS's validator would reject come back as warnings."""
    from racer.reward.check import check_reward_file

    warnings: list[str] = []
    seen: set[tuple[str, str]] = set()
    for worker in workers:
        key = (worker.track, worker.challenge.race_type)
        if key in seen:
            continue
        seen.add(key)
        report = check_reward_file(path, Track.load(worker.track), worker.challenge.race_type, metadata, quick=True,
                                   time_budget_s=2.0)  # fmt: skip
        refused = [f for f in report.errors if f.params is not None or "raised" in f.message or "syntax" in f.message]
        if refused:
            details = "\n".join(f.format() for f in refused)
            raise RunConfigError(
                f"{path}: the reward function fails on params DeepRacer produces on {worker.track} "
                f"({worker.challenge.race_type}):\n{details}\nfix: handle these cases (see `racer reward test {path} "
                f"--track {worker.track} --race-type {worker.challenge.race_type}`)"
            )
        warnings += [f.format() for f in report.findings if f not in refused]
    return warnings


def load_network(folder: Path, metadata: ModelMetadata, stack_size: int = 1) -> tuple[NetworkFile | None, list[str]]:
    """network.json when model_metadata.json names it, checked and measured once (racer.shared.policy.network_file)
    with the run's stack_size (the first conv reads C * stack_size channels, so a stack costs more); a network.json
    that model_metadata.json does not name is only a warning."""
    from racer.shared.policy.networks import policy_config_from_metadata

    try:
        network = network_for_metadata(folder, metadata)
    except NetworkFileError as error:
        raise RunConfigError(str(error)) from error
    if network is None:
        if not (folder / NETWORK_FILE).is_file():
            return None, []
        return None, [f"{folder / NETWORK_FILE}: not used: model_metadata.json names {metadata.neural_network}"]
    findings = network_size_findings(
        policy_config_from_metadata(metadata, network, stack_size), str(folder / NETWORK_FILE)
    )
    if findings.errors:
        raise RunConfigError("; ".join(findings.errors))
    return network, list(findings.warnings)


def _check_clone_network(store: ObjectStore, source_prefix: str, network: NetworkFile | None, ours: str) -> None:
    try:
        raw = store.get_bytes(ModelLayout(source_prefix).network)
    except ObjectNotFoundError as error:
        raise CloneError(f"cannot clone {source_prefix!r}: it has no model/{NETWORK_FILE} for its network") from error
    try:
        theirs = parse_network_file(json.loads(raw), f"{source_prefix}/model/{NETWORK_FILE}").to_dict()
    except (ValueError, NetworkFileError) as error:
        raise CloneError(f"cannot clone {source_prefix!r}: {error}") from error
    difference = network_difference(network.to_dict() if network else None, theirs)
    if difference:
        raise CloneError(
            f"cannot clone {source_prefix!r}: its network differs from {Path(ours).parent / NETWORK_FILE} at "
            f"{difference} (ours vs theirs); fix: clone with the same network.json, or train this one from scratch"
        )


def _source_stack_size(store: ObjectStore, source_prefix: str) -> tuple[int, str]:
    """The clone source's stack_size and the file that says it (DeepRacer's 1 when it has no hyperparameters)."""
    where = ModelLayout(source_prefix).hyperparameters
    try:
        data = json.loads(store.get_bytes(where).decode("utf-8-sig"))
    except ObjectNotFoundError:
        return 1, f"{where} (missing: DeepRacer's 1)"
    except ValueError as error:
        raise CloneError(f"cannot clone {source_prefix!r}: {where} is not JSON: {error}") from error
    value = data.get("stack_size", 1) if isinstance(data, dict) else 1
    try:
        return int(value), where
    except (TypeError, ValueError) as error:
        raise CloneError(f"cannot clone {source_prefix!r}: {where}: stack_size {value!r} is not a number") from error


def check_clone_source(
    store: ObjectStore,
    source_prefix: str,
    metadata: ModelMetadata,
    ours: str,
    network: NetworkFile | None = None,
    stack_size: int = 1,
) -> None:
    """A clone continues another model's weights: same algorithm, action-space type, number of actions, sensors,
    network (your own network: the same network.json) and frame stack (the first conv's input channels). Raises
    CloneError naming what differs and the fix."""
    source_layout = ModelLayout(source_prefix)
    try:
        raw = store.get_bytes(source_layout.model_metadata)
    except ObjectNotFoundError as error:
        raise CloneError(
            f"cannot clone {source_prefix!r}: it has no model/model_metadata.json in {store.describe()}"
        ) from error
    source = parse_model_metadata(json.loads(raw), source=f"{store.describe()}/{source_layout.model_metadata}")
    if source.training_algorithm != metadata.training_algorithm:
        raise CloneError(
            f"{ours}: training_algorithm: cannot clone {source_prefix!r}: it was trained with "
            f"{source.training_algorithm}, this model asks for {metadata.training_algorithm}; the "
            f"networks differ (SAC clones only SAC, clipped PPO only clipped PPO); fix: clone a "
            f"{metadata.training_algorithm} model, or train this one from scratch"
        )
    if source.action_space_type != metadata.action_space_type:
        raise CloneError(
            f"cannot clone {source_prefix!r}: its action space is {source.action_space_type}, "
            f"{ours} is {metadata.action_space_type}"
        )
    if source.num_actions != metadata.num_actions:
        raise CloneError(
            f"cannot clone {source_prefix!r}: it has {source.num_actions} actions, "
            f"{ours} has {metadata.num_actions} actions; the number of actions must match "
            f"(their values may change)"
        )
    if (source.sensors, source.neural_network) != (metadata.sensors, metadata.neural_network):
        raise CloneError(
            f"cannot clone {source_prefix!r}: sensors/network {source.sensors} "
            f"{source.neural_network} differ from {ours}: {metadata.sensors} "
            f"{metadata.neural_network}"
        )
    if network is not None or source.neural_network not in NEURAL_NETWORKS:
        _check_clone_network(store, source_prefix, network, ours)
    theirs, their_file = _source_stack_size(store, source_prefix)
    if theirs != stack_size:
        raise CloneError(
            f"cannot clone {source_prefix!r}: stack_size {stack_size} in {Path(ours).parent / 'hyperparameters.json'} "
            f"vs {theirs} in {their_file} (ours vs theirs): the first conv layer reads one channel per stacked frame, "
            f"so the weights do not fit; fix: set stack_size to {theirs}, or train this one from scratch"
        )


def preflight(
    custom_files: Path,
    run: RunOptions,
    pretrained_prefix: str | None = None,
    store: ObjectStore | None = None,
) -> PreflightReport:
    """Every check that needs no running server. Raises a user error (file, field, fix) or returns the parsed
    settings and warnings. `run`: the settings every worker gets before workers.json; `store`: where a clone source
    is looked up (only when it needs no server to read)."""
    folder = Path(custom_files)
    _check_files_present(folder)
    metadata_path, hyperparameters_path = folder / "model_metadata.json", folder / "hyperparameters.json"
    metadata = load_model_metadata(metadata_path)
    hyperparameters, warnings = load_hyperparameters(hyperparameters_path)
    warnings += _check_combination(
        metadata, hyperparameters, metadata_path, hyperparameters_path, _given_keys(hyperparameters_path)
    )
    network, network_warnings = load_network(folder, metadata, hyperparameters.stack_size)
    try:
        preset = load_preset(folder, metadata.training_algorithm)
    except PresetError as error:
        raise RunConfigError(str(error)) from error
    warnings += network_warnings
    load_reward_function(folder / "reward_function.py")
    workers = load_worker_settings(folder, run)
    for worker_id, worker in enumerate(workers):
        try:  # a track name no worker could find fails here, listing where it looked, not in every worker
            Track.load(worker.track)
        except TrackError as error:
            raise RunConfigError(f"worker {worker_id}: track {worker.track!r}: {error}") from error
    warnings += _check_reward_over_track(folder / "reward_function.py", workers, metadata)
    if hyperparameters.num_episodes_between_training < run.num_workers:
        idle = run.num_workers - hyperparameters.num_episodes_between_training
        warnings.append(
            f"{hyperparameters_path}: num_episodes_between_training: "
            f"{hyperparameters.num_episodes_between_training} episodes per iteration for {run.num_workers} "
            f"workers: {idle} worker(s) only wait (worker 0 still evaluates)"
        )
    if pretrained_prefix and store is not None:
        check_clone_source(store, pretrained_prefix, metadata, str(metadata_path), network, hyperparameters.stack_size)
    return PreflightReport(metadata, hyperparameters, tuple(workers), tuple(warnings), network, preset)


def read_checked_files(custom_files: Path, run: RunOptions) -> PreflightReport:
    """What `preflight` returns, read without its checks, for a trainer whose launcher (`racer train`) has run the
    preflight on these files before anything started: a run checks its custom files once."""
    folder = Path(custom_files)
    metadata = load_model_metadata(folder / "model_metadata.json")
    hyperparameters, _warnings = load_hyperparameters(folder / "hyperparameters.json")
    try:
        network = network_for_metadata(folder, metadata)
        preset = load_preset(folder, metadata.training_algorithm)
    except (NetworkFileError, PresetError) as error:
        raise RunConfigError(str(error)) from error
    workers = load_worker_settings(folder, run)
    return PreflightReport(metadata, hyperparameters, tuple(workers), (), network, preset)
