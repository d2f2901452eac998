"""Start and stop real `redis-server` and `minio` processes on loopback ports.

Used by `racer train` (the embedded default) and by the test fixtures. Each server gets its own
data directory; the child is killed by the kernel if this process dies (PR_SET_PDEATHSIG), so a
crashed run or test leaves no server behind. PR_SET_PDEATHSIG follows the *thread* that spawned
the child: start servers from the main thread (or one that lives as long as the server).
"""

from __future__ import annotations

import ctypes
import os
import shutil
import signal
import socket
import subprocess
import time
import urllib.error
import urllib.request
from pathlib import Path

from racer.defaults import REDIS_CONF

_PR_SET_PDEATHSIG = 1


def _die_with_parent() -> None:
    """preexec_fn: ask the kernel to SIGKILL the child when the parent dies, and detach from the terminal's Ctrl-C."""
    libc = ctypes.CDLL("libc.so.6", use_errno=True)
    libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL)
    os.setpgrp()


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def find_executable(name: str) -> str:
    """Find `redis-server` or `minio` on PATH or in Go's bin folder; a clear error otherwise."""
    found = shutil.which(name)
    if found:
        return found
    for candidate in (Path.home() / "go" / "bin" / name, Path("/usr/local/bin") / name):
        if candidate.is_file() and os.access(candidate, os.X_OK):
            return str(candidate)
    raise FileNotFoundError(
        f"`{name}` was not found on PATH or in ~/go/bin. Run ./scripts/setup.sh, which installs redis-server "
        "from Debian (`scripts/setup.sh --with-minio` also builds MinIO, needed only for S3 runs and the tests)."
    )


class _ServerProcess:
    name = "server"

    def __init__(self, data_dir: Path, port: int | None = None, log_path: Path | None = None):
        self.data_dir = Path(data_dir)
        self.data_dir.mkdir(parents=True, exist_ok=True)
        self.port = port or free_port()
        self.log_path = log_path or (self.data_dir / f"{self.name}.log")
        self._process: subprocess.Popen | None = None

    def _command(self) -> list[str]:
        raise NotImplementedError

    def _environment(self) -> dict[str, str]:
        return dict(os.environ)

    def _is_ready(self) -> bool:
        raise NotImplementedError

    @property
    def running(self) -> bool:
        return self._process is not None and self._process.poll() is None

    @property
    def exit_status(self) -> int | None:
        """The exit status of a server that has exited (negative: killed by that signal), else None."""
        return self._process.poll() if self._process is not None else None

    @property
    def pid(self) -> int | None:
        return self._process.pid if self._process else None

    def start(self, timeout_s: float = 30.0) -> None:
        if self.running:
            return
        log = open(self.log_path, "ab")
        self._process = subprocess.Popen(
            self._command(), stdout=log, stderr=subprocess.STDOUT, env=self._environment(), preexec_fn=_die_with_parent
        )
        log.close()
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if self._process.poll() is not None:
                raise RuntimeError(
                    f"{self.name} exited with status {self._process.returncode} at start; see {self.log_path}:\n"
                    + self.log_path.read_text(errors="replace")[-2000:]
                )
            if self._is_ready():
                return
            time.sleep(0.05)
        self.stop()
        raise TimeoutError(
            f"{self.name} did not become ready on port {self.port} within {timeout_s} s; see {self.log_path}"
        )

    def stop(self, timeout_s: float = 10.0) -> None:
        if self._process is None:
            return
        if self._process.poll() is None:
            self._process.terminate()
            try:
                self._process.wait(timeout_s)
            except subprocess.TimeoutExpired:
                self._process.kill()
                self._process.wait()
        self._process = None

    def kill(self) -> None:
        """SIGKILL, as a crash would (fault tests)."""
        if self._process is not None and self._process.poll() is None:
            self._process.kill()
            self._process.wait()
        self._process = None

    def restart(self, timeout_s: float = 30.0) -> None:
        self.stop()
        self.start(timeout_s)

    def __enter__(self):
        self.start()
        return self

    def __exit__(self, *exc_info) -> None:
        self.stop()


class RedisServer(_ServerProcess):
    """redis-server with racer's redis.conf (racer/defaults), overridden to bind loopback on a chosen port."""

    name = "redis-server"

    def __init__(self, data_dir: Path, port: int | None = None, conf_path: Path | None = None, **kwargs):
        super().__init__(data_dir, port, **kwargs)
        self.conf_path = conf_path or REDIS_CONF

    @property
    def url(self) -> str:
        return f"redis://127.0.0.1:{self.port}/0"

    def _command(self) -> list[str]:
        return [
            find_executable("redis-server"),
            str(self.conf_path),
            "--port",
            str(self.port),
            "--bind",
            "127.0.0.1",
            "--dir",
            str(self.data_dir),
            "--daemonize",
            "no",
            "--logfile",
            "",
        ]

    def _is_ready(self) -> bool:
        try:
            with socket.create_connection(("127.0.0.1", self.port), timeout=0.5) as sock:
                sock.sendall(b"PING\r\n")
                return sock.recv(16).startswith(b"+PONG")
        except OSError:
            return False


class MinioServer(_ServerProcess):
    """A real MinIO server on loopback with its own data directory and root credentials."""

    name = "minio"

    def __init__(
        self,
        data_dir: Path,
        port: int | None = None,
        access_key: str = "racer-admin",
        secret_key: str = "racer-admin-secret",
        **kwargs,
    ):
        super().__init__(data_dir, port, **kwargs)
        self.console_port = free_port()
        self.access_key = access_key
        self.secret_key = secret_key

    @property
    def endpoint_url(self) -> str:
        return f"http://127.0.0.1:{self.port}"

    def _command(self) -> list[str]:
        return [
            find_executable("minio"),
            "server",
            str(self.data_dir / "data"),
            "--address",
            f"127.0.0.1:{self.port}",
            "--console-address",
            f"127.0.0.1:{self.console_port}",
            "--quiet",
        ]

    def _environment(self) -> dict[str, str]:
        env = dict(os.environ)
        env.update(
            MINIO_ROOT_USER=self.access_key,
            MINIO_ROOT_PASSWORD=self.secret_key,
            MINIO_BROWSER="off",
            MINIO_UPDATE="off",
        )
        return env

    def _is_ready(self) -> bool:
        try:
            with urllib.request.urlopen(f"{self.endpoint_url}/minio/health/ready", timeout=0.5) as response:
                return response.status == 200
        except (urllib.error.URLError, OSError):
            return False
