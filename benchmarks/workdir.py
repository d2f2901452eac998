"""What every bench shares: the temporary folder a benchmark's training run writes to (store, logs, custom files),
the iteration records it reads back, and the machine a figure came from."""

from __future__ import annotations

import json
import shutil
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING

import click

from racer.shared import model_layout

if TYPE_CHECKING:
    from racer.local.run import LocalRunPlan


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


def read_iteration_records(store_root: Path, plan: LocalRunPlan) -> list[dict]:
    """Iteration summaries the trainer also writes to the store (Redis is gone once the run stops)."""
    path = store_root / plan.model_prefix / model_layout.ITERATIONS_LOG
    if not path.is_file():
        return []
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def native_bf16_available() -> bool:
    """True when this CPU has bf16 arithmetic (AVX512-BF16 or AMX tiles): bf16 is then fast; elsewhere oneDNN
    emulates it with the same rounding, many times slower. Informative only: no default depends on it."""
    import torch

    checks = [getattr(torch.cpu, name, None) for name in ("_is_avx512_bf16_supported", "_is_amx_tile_supported")]
    return any(check() for check in checks if check is not None)


def cpu_description() -> str:
    """The CPU a figure came from, e.g. 'Intel(R) Xeon(R) Processor, 2 cores, avx512_bf16 amx_bf16' (Linux only)."""
    import os

    model, flags = "unknown CPU", set()
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as cpuinfo:
            for line in cpuinfo:
                key, _, value = line.partition(":")
                if key.strip() == "model name":
                    model = value.strip()
                elif key.strip() == "flags":
                    flags = set(value.split())
    except OSError:
        pass
    wide = [flag for flag in ("avx2", "avx512f", "avx512_bf16", "amx_bf16") if flag in flags]
    return f"{model}, {len(os.sched_getaffinity(0))} cores, {' '.join(wide) or 'no AVX2'}"
