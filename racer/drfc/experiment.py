"""A DeepRacer-for-Cloud experiment: where its files are, and everything they set, read before anything starts.

Where DRfC looks (deepracer-for-cloud 2eb1a1f1 `bin/activate.sh`, `scripts/training/prepare-config.py`):

- system.env lives in the DRfC folder (DR_DIR) and is read first; run.env second, so it overrides system.env and
  may refer to its variables. racer reads system.env beside run.env, or two levels up when the folder is
  `experiments/<name>/`; an experiment without one is read without it.
- A run.env given by path (`activate.sh path/run.env`, lines 155-157) is only DR_CONFIG: system.env, worker-N.env and
  custom_files/ still come from DR_DIR, the folder activate.sh lives in (lines 132-134, 70-71; prepare-config.py
  lines 143-146; bin/scripts_wrapper.sh lines 77-85, dr-upload-custom-files). racer takes them from $DR_DIR when the
  environment sets it (racer.shared.config.drfc_dir), else from run.env's folder, and says which.
- DR_EXPERIMENT_NAME in system.env sends DRfC to `experiments/<name>/run.env` (and its worker-N.env and
  custom_files/); `--drfc` given the DRfC folder does the same, and `--drfc experiments/<name>` is `activate.sh -e
  <name>`, which wins over system.env's name.
- worker-N.env (N = 2 .. DR_WORKERS) lies beside run.env and is read only when DR_TRAIN_MULTI_CONFIG is exactly
  `True` (DRfC compares the text) and DR_WORKERS > 1. The files apply one after another to the same environment, so a
  later worker keeps what an earlier worker-N.env set unless its own file sets it again.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from racer.drfc.shell_env import Assignment, DrfcFileError, EnvFile, read_shell_env
from racer.drfc.worker_env import read_worker_env

__all__ = ["CUSTOM_FILES", "DrfcExperiment", "read_experiment"]

RUN_ENV = "run.env"
SYSTEM_ENV = "system.env"
CUSTOM_FILES = "custom_files"
EXPERIMENTS = "experiments"
WORKER_ENV = re.compile(r"worker-(\d+)\.env")
MULTI_CONFIG_ON = "True"
"""The one spelling of DR_TRAIN_MULTI_CONFIG that DRfC's start.sh and prepare-config.py take as on."""

Env = Mapping[str, Assignment]
"""Variable name -> the assignment in force (the last one read)."""


@dataclass(frozen=True)
class DrfcExperiment:
    folder: Path
    """The experiment's folder: run.env, worker-N.env and custom_files/."""
    run_env: Path
    system_env: Path | None
    env: Env
    """system.env, then run.env."""
    worker_envs: tuple[Env, ...]
    """One per worker: `env`, then worker-2.env .. worker-N.env in turn (multi-config), else `env` for every worker."""
    multi_config: bool
    worker_files: tuple[EnvFile, ...]
    """The worker-N.env files read, worker-2.env first."""
    notes: tuple[str, ...]
    warnings: tuple[str, ...] = ()
    """Lines DRfC reads otherwise than they look, each with file:line (racer reads them as they look)."""

    @property
    def num_workers(self) -> int:
        return len(self.worker_envs)

    @property
    def custom_files(self) -> Path:
        return self.folder / CUSTOM_FILES

    @property
    def files(self) -> tuple[Path, ...]:
        """Every file read, in the order read."""
        system = (self.system_env,) if self.system_env is not None else ()
        return (*system, self.run_env, *(f.path for f in self.worker_files))


def read_experiment(
    path: Path, num_workers: int | None = None, training: bool = True, drfc_dir: Path | None = None
) -> DrfcExperiment:
    """Read the experiment at `path` (a folder or its run.env); `num_workers`: the command line's --workers, which
    stands for DR_WORKERS (so it also decides which worker-N.env files are read). `training` False: as DRfC's
    evaluation, which reads no worker-N.env. `drfc_dir`: $DR_DIR, where a run.env given by path has its system.env,
    worker-N.env and custom_files/ (None: unset, so they are run.env's neighbours)."""
    path = Path(path).absolute()
    notes: list[str] = []
    run_env: Path | None
    if path.is_file():
        folder, run_env = _companions_folder(path, drfc_dir), path
    elif path.is_dir():
        folder, run_env = path, None
    else:
        raise DrfcFileError(f"{path}: no such file or folder (--drfc takes a DRfC folder or its run.env)")
    by_dr_dir = run_env is not None and drfc_dir is not None
    system_env = _file_or_none(folder / SYSTEM_ENV) if by_dr_dir else _system_env(folder)
    drfc_folder = system_env.parent if system_env is not None else folder
    values: dict[str, str] = {"DR_DIR": str(drfc_folder)}  # activate.sh exports DR_DIR before it reads the files
    env: dict[str, Assignment] = {}
    warnings: list[str] = []
    if system_env is not None:
        _absorb(read_shell_env(system_env, values), env, values, notes, warnings)
        folder, run_env = _experiment_folder(folder, run_env, drfc_folder, system_env, env, values)
    if run_env is not None:
        notes.append(_companions_note(path, folder, system_env, drfc_dir))
    run_env = run_env or folder / RUN_ENV
    if not run_env.is_file():
        raise DrfcFileError(
            f"{folder}: no {RUN_ENV}: give --drfc the folder that holds a DRfC experiment's run.env, or the file"
        )
    _absorb(read_shell_env(run_env, values), env, values, notes, warnings)
    if not training:
        return DrfcExperiment(folder, run_env, system_env, env, (dict(env),), False, (), tuple(notes), tuple(warnings))
    count = num_workers if num_workers is not None else _num_workers(env)
    multi_config = _multi_config(env, count, notes)
    worker_envs: list[Env] = [dict(env)]
    worker_files: list[EnvFile] = []
    if multi_config:
        for number in range(2, count + 1):
            worker_path = folder / f"worker-{number}.env"
            if not worker_path.is_file():
                raise DrfcFileError(
                    f"{worker_path}: missing: with DR_TRAIN_MULTI_CONFIG=True and {count} workers DRfC's "
                    f"prepare-config.py reads worker-2.env to worker-{count}.env, and stops without this one"
                )
            worker_file = read_worker_env(worker_path)
            worker_files.append(worker_file)
            warnings += worker_file.warnings
            worker_envs.append({**worker_envs[-1], **{a.name: a for a in worker_file.assignments}})
    else:
        worker_envs *= count
    notes += _unread_worker_files(folder, multi_config, count)
    return DrfcExperiment(
        folder=folder,
        run_env=run_env,
        system_env=system_env,
        env=env,
        worker_envs=tuple(worker_envs),
        multi_config=multi_config,
        worker_files=tuple(worker_files),
        notes=tuple(notes),
        warnings=tuple(warnings),
    )


def _companions_folder(run_env: Path, drfc_dir: Path | None) -> Path:
    """Where a run.env given by path has its companions: $DR_DIR when set (as in DRfC), else its own folder."""
    if drfc_dir is None:
        return run_env.parent
    if not drfc_dir.is_dir():
        raise DrfcFileError(
            f"DR_DIR={drfc_dir}: not a folder; DRfC reads a run.env's system.env, worker-N.env and custom_files/ "
            f"from DR_DIR (bin/activate.sh sets it to its own folder), and so does racer: set DR_DIR to the DRfC "
            f"folder, or unset it to read them beside {run_env}"
        )
    return drfc_dir.absolute()


def _companions_note(run_env: Path, folder: Path, system_env: Path | None, drfc_dir: Path | None) -> str:
    system = f"system.env {system_env}" if system_env is not None else "no system.env"
    if drfc_dir is not None:
        return (
            f"{run_env} given by path: worker-N.env and custom_files/ from {folder}, {system}: from $DR_DIR "
            f"({drfc_dir}), as in DRfC, where activate.sh sets DR_DIR to its own folder and reads them there"
        )
    return (
        f"{run_env} given by path: worker-N.env and custom_files/ from {folder}, {system}: beside it, since DR_DIR "
        f"is not set (DRfC reads them from its own folder, which its activate.sh exports as DR_DIR)"
    )


def _file_or_none(path: Path) -> Path | None:
    return path if path.is_file() else None


def _system_env(folder: Path) -> Path | None:
    for candidate in (folder / SYSTEM_ENV, folder.parent.parent / SYSTEM_ENV):
        if candidate.is_file() and (candidate.parent == folder or folder.parent.name == EXPERIMENTS):
            return candidate
    return None


def _absorb(
    file: EnvFile, env: dict[str, Assignment], values: dict[str, str], notes: list[str], warnings: list[str]
) -> None:
    for assignment in file.assignments:
        env[assignment.name] = assignment
        values[assignment.name] = assignment.value
    notes += file.notes
    warnings += file.warnings


def _experiment_folder(
    folder: Path,
    run_env: Path | None,
    drfc_dir: Path,
    system_env: Path,
    env: dict[str, Assignment],
    values: dict[str, str],
) -> tuple[Path, Path | None]:
    """Where DR_EXPERIMENT_NAME sends DRfC (activate.sh `dr-update-env`)."""
    if folder != drfc_dir:  # experiments/<name>/ given: `activate.sh -e <name>`, which wins over system.env
        values["DR_EXPERIMENT_NAME"] = folder.name
        return folder, run_env
    named = env.get("DR_EXPERIMENT_NAME")
    if named is None or not named.value:
        return folder, run_env
    experiment = drfc_dir / EXPERIMENTS / named.value
    if run_env is not None and run_env.parent != experiment:
        raise DrfcFileError(
            f"{named.where}: DR_EXPERIMENT_NAME={named.value}: DRfC would read {experiment / RUN_ENV}, not "
            f"{run_env}; give --drfc {experiment}, or remove DR_EXPERIMENT_NAME from {system_env}"
        )
    if not (experiment / RUN_ENV).is_file():
        raise DrfcFileError(
            f"{named.where}: DR_EXPERIMENT_NAME={named.value}: no {experiment / RUN_ENV} (DRfC stops here too)"
        )
    return experiment, run_env


def _num_workers(env: Env) -> int:
    assignment = env.get("DR_WORKERS")
    if assignment is None:
        return 1  # prepare-config.py: os.environ.get('DR_WORKERS', 1)
    try:
        count = int(assignment.value)
    except ValueError:
        count = 0
    if count < 1:
        raise DrfcFileError(
            f"{assignment.where}: DR_WORKERS={assignment.value!r} is not a number of workers (1 or more)"
        )
    return count


def _multi_config(env: Env, count: int, notes: list[str]) -> bool:
    assignment = env.get("DR_TRAIN_MULTI_CONFIG")
    if assignment is None:
        return False
    if assignment.value.lower() == "true" and assignment.value != MULTI_CONFIG_ON:
        notes.append(
            f"{assignment.where}: DR_TRAIN_MULTI_CONFIG={assignment.value}: DRfC takes only the exact text "
            f"'True' as on, so this is off there, and in racer: worker-N.env files are not read"
        )
    return assignment.value == MULTI_CONFIG_ON and count > 1


def _unread_worker_files(folder: Path, multi_config: bool, count: int) -> list[str]:
    present = sorted(
        (int(match.group(1)), entry.name)
        for entry in folder.iterdir()
        if entry.is_file() and (match := WORKER_ENV.fullmatch(entry.name))
    )
    unread = [name for number, name in present if not multi_config or not 2 <= number <= count]
    if not unread:
        return []
    if multi_config:
        reason = f"DRfC reads worker-2.env to worker-{count}.env for {count} workers"
    elif count == 1:
        reason = "there is one worker"
    else:
        reason = "DR_TRAIN_MULTI_CONFIG is not True"
    return [f"{folder}: not read, as in DRfC ({reason}): {', '.join(unread)}"]
