"""The temporary folder a benchmark's training run writes to (store, logs, custom files)."""

from __future__ import annotations

import shutil
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import click


@contextmanager
def bench_workdir(prefix: str) -> Iterator[Path]:
    """A new folder under the system's temp folder, removed when the bench ends well: one run writes hundreds of MB
    of checkpoints, and a few forgotten runs fill a disk. A bench that fails keeps it, and says where, for its logs."""
    workdir = Path(tempfile.mkdtemp(prefix=prefix))
    finished = False
    try:
        yield workdir
        finished = True
    finally:
        if finished:
            shutil.rmtree(workdir, ignore_errors=True)
        else:
            click.echo(f"the bench's folder is kept for its logs: {workdir}", err=True)
