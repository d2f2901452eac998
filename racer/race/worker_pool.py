"""Long-lived race workers (`python -m racer.race.worker --serve`), one per core, taking entrants in turn.

A fresh process per entrant would pay seconds of CPU for imports before its first step, a large share of a
time-trial entrant's cost on 2 cores. A worker that dies (a native crash, the OOM killer) takes only its current
entrant with it: the pool notes which one and starts a new worker for the rest. A worker retires after
TASKS_PER_WORKER entrants, because with videos on the process grows with every evaluation, which a long race would
otherwise pile up.
"""

from __future__ import annotations

import selectors
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path

TASKS_PER_WORKER = 8
"""Entrants a worker races before a fresh one replaces it: the imports are paid once per eight entrants, and the
memory the videos leave behind does not pile up."""


@dataclass
class _Worker:
    process: subprocess.Popen
    task_path: Path | None = None
    label: str = ""
    tasks_done: int = 0


@dataclass(frozen=True)
class Finished:
    label: str
    task_path: Path
    pid: int
    """The worker process's, for the log."""
    exit_status: int | None
    """None when the worker finished the task (its result file says how it went); the exit status when it died."""


@dataclass
class WorkerPool:
    size: int
    env: dict[str, str]
    tasks_per_worker: int = TASKS_PER_WORKER
    _selector: selectors.BaseSelector = field(default_factory=selectors.DefaultSelector)
    _idle: list[_Worker] = field(default_factory=list)
    _busy: list[_Worker] = field(default_factory=list)

    def _start(self) -> _Worker:
        process = subprocess.Popen(
            [sys.executable, "-m", "racer.race.worker", "--serve"],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
            bufsize=1,
            env=self.env,
        )
        worker = _Worker(process)
        self._selector.register(process.stdout, selectors.EVENT_READ, worker)
        return worker

    def has_room(self) -> bool:
        return len(self._busy) < self.size

    def busy(self) -> bool:
        return bool(self._busy)

    def submit(self, label: str, task_path: Path) -> None:
        worker = self._idle.pop() if self._idle else self._start()
        worker.task_path, worker.label = task_path, label
        worker.process.stdin.write(f"{task_path}\n")
        worker.process.stdin.flush()
        self._busy.append(worker)

    def wait(self) -> list[Finished]:
        """Block until at least one busy worker finishes its task or dies."""
        finished = []
        for key, _ in self._selector.select():
            worker: _Worker = key.data
            line = worker.process.stdout.readline()
            if line.startswith("done "):
                self._busy.remove(worker)
                worker.tasks_done += 1
                if worker.tasks_done < self.tasks_per_worker:
                    self._idle.append(worker)
                else:
                    self._retire(worker)
                finished.append(Finished(worker.label, worker.task_path, worker.process.pid, None))
                continue
            self._selector.unregister(worker.process.stdout)  # end of file: the worker died
            worker.process.stdin.close()
            worker.process.stdout.close()
            exit_status = worker.process.wait()
            if worker in self._busy:
                self._busy.remove(worker)
                finished.append(Finished(worker.label, worker.task_path, worker.process.pid, exit_status))
            else:  # died between tasks: nothing lost
                self._idle.remove(worker)
        return finished

    def _retire(self, worker: _Worker) -> None:
        self._selector.unregister(worker.process.stdout)
        worker.process.stdin.close()  # end of its task list: it exits
        worker.process.wait()
        worker.process.stdout.close()

    def close(self) -> None:
        for worker in self._idle + self._busy:
            self._selector.unregister(worker.process.stdout)
            worker.process.stdin.close()
            if worker in self._busy:
                worker.process.kill()
            worker.process.wait()
            worker.process.stdout.close()
        self._idle.clear()
        self._busy.clear()
        self._selector.close()
