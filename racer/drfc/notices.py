"""What a DRfC experiment asks for that racer does not do: each variable named once, with what racer does instead."""

from __future__ import annotations

from racer.drfc.experiment import DrfcExperiment
from racer.drfc.shell_env import Assignment
from racer.drfc.training_params import PER_WORKER_VARIABLES
from racer.drfc.variables import Use, variable

__all__ = ["variable_notes"]

DRFC_COMMIT = "2eb1a1f1"


def variable_notes(experiment: DrfcExperiment, command: str) -> list[str]:
    """Notes for `command` ("train" or "evaluate"): the variables set that racer does not honour there, grouped by
    what racer does instead, and the ones racer does not know. Each variable is named once, with the first value
    that asks for something (worker-N.env's per-worker variables included: its other lines have no effect, which
    training_params.worker_file_notes says)."""
    values = {name: a.value for name, a in experiment.env.items()}
    assignments: dict[str, list[Assignment]] = {}
    for assignment in (
        *experiment.env.values(),
        *(a for file in experiment.worker_files for a in file.assignments if a.name in PER_WORKER_VARIABLES),
    ):
        assignments.setdefault(assignment.name, []).append(assignment)
    groups: dict[str, list[str]] = {}
    unknown: list[str] = []
    for name, seen in assignments.items():
        known = variable(name)
        if known is None:
            unknown.append(f"{name} ({seen[0].where})")
            continue
        if known.use(command) is not Use.NOT_HONOURED:
            continue
        asking = [a for a in seen if not known.is_inert(a.value, values)]
        if asking:
            groups.setdefault(known.racer, []).append(f"{name}={asking[0].value}")
    notes = [f"not honoured: {', '.join(names)}: {text}" for text, names in groups.items()]
    if unknown:
        notes.append(
            f"ignored, not a variable of DRfC's templates or prepare-config.py at {DRFC_COMMIT}: {', '.join(unknown)}"
        )
    return notes
