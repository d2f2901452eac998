"""`racer train`: the whole system as local processes (the embedded default).

One command starts a redis-server with the project's redis.conf (loopback only), optionally a MinIO
server, the trainer and N rollout workers, then shows live progress until training ends or Ctrl-C.
Every child dies with this process (PR_SET_PDEATHSIG), so nothing is left behind.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from dataclasses import dataclass
from pathlib import Path

import click

from racer.local.progress import ProgressDisplay
from racer.local.services import MinioServer, RedisServer, _die_with_parent
from racer.local.supervisor import RunSupervisor, stop_children
from racer.rollout_worker.cli import EXIT_RUN_CANNOT_GO_ON
from racer.shared.config import LocalStoreSettings, RedisSettings, S3Settings, ServiceSettings
from racer.shared.redis_connection import RedisLink, RedisUnavailableError
from racer.shared.run_settings import RunOptions
from racer.shared.sim.scene.gl import ensure_gl_backend
from racer.shared.sim.scene.renderer import apply_renderer, choose_renderer
from racer.shared.store import S3Store, open_store
from racer.shared.transport.channels import RunChannel


@dataclass(frozen=True)
class LocalRunPlan:
    model_prefix: str
    custom_files: Path
    run: RunOptions
    """The settings every worker gets (`racer train`'s options): what the launcher's preflight checks and the
    trainer is given."""
    max_episodes: int | None
    max_minutes: float | None
    use_minio: bool
    log_dir: Path
    seed: int = 0
    pretrained_prefix: str | None = None
    pretrained_checkpoint: str = "last"
    viewer_host: str = "127.0.0.1"
    viewer_port: int | None = None
    """The live web page (`racer view --live`) listens here; None: no viewer."""
    envs_per_worker: int | None = None
    """None: the rollout command's default."""
    trainer_options: tuple[str, ...] = ()
    """Further `racer trainer` options, e.g. ("--sac-updates-per-transition", "0.5")."""
    renderer: str = "auto"
    """Which device draws the workers' cameras (`--renderer`: auto, cpu or gpu; MUJOCO_GL overrides it)."""


def service_environment(settings: ServiceSettings) -> dict[str, str]:
    """The environment that gives a child process these service settings (read back by shared/config.py)."""
    env = dict(os.environ)
    env["RACER_REDIS_URL"] = settings.redis.url
    env["RACER_CONNECT_TIMEOUT_S"] = str(settings.redis.connect_timeout_s)
    if isinstance(settings.store, S3Settings):
        env["RACER_STORE"] = f"s3://{settings.store.bucket}"
        if settings.store.endpoint_url:
            env["S3_ENDPOINT_URL"] = settings.store.endpoint_url
        if settings.store.access_key_id:
            env["AWS_ACCESS_KEY_ID"] = settings.store.access_key_id
        if settings.store.secret_access_key:
            env["AWS_SECRET_ACCESS_KEY"] = settings.store.secret_access_key
        if settings.store.session_token:
            env["AWS_SESSION_TOKEN"] = settings.store.session_token
        env["AWS_DEFAULT_REGION"] = settings.store.region
    else:
        env["RACER_STORE"] = str(settings.store.root)
    env.setdefault("LP_NUM_THREADS", "1")  # one llvmpipe render thread per worker: workers already fill the cores
    return env


def trainer_argv(plan: LocalRunPlan) -> list[str]:
    """The `racer trainer` command line of a local run. `--preflight-passed`: the launcher has run the preflight
    (`check_before_start`), so the trainer reads the custom files without checking them a second time."""
    args = ["trainer", "--model-prefix", plan.model_prefix, "--custom-files", str(plan.custom_files)]
    args += [*plan.run.trainer_args(), "--seed", str(plan.seed), "--preflight-passed"]
    if plan.max_episodes is not None:
        args += ["--max-episodes", str(plan.max_episodes)]
    if plan.max_minutes is not None:
        args += ["--max-minutes", str(plan.max_minutes)]
    if plan.pretrained_prefix:
        args += ["--pretrained-prefix", plan.pretrained_prefix, "--pretrained-checkpoint", plan.pretrained_checkpoint]
    return args + list(plan.trainer_options)


VIEWER = "viewer"
"""The child process name of the web page server."""


def viewer_url(host: str, port: int) -> str:
    shown = "localhost" if host in {"127.0.0.1", "::1", "localhost"} else host
    return f"http://{shown}:{port}/"


class LocalRun:
    """Owns the processes of one local training run."""

    def __init__(self, plan: LocalRunPlan, base_settings: ServiceSettings):
        self.plan = plan
        self.base_settings = base_settings
        self.redis: RedisServer | None = None
        self.minio: MinioServer | None = None
        self.children: dict[str, subprocess.Popen] = {}
        self.settings: ServiceSettings | None = None

    def start_services(self) -> ServiceSettings:
        apply_renderer(choose_renderer(self.plan.renderer))  # the vendor before the backend; children inherit both
        ensure_gl_backend()  # MUJOCO_GL unset: EGL, else OSMesa, probed once; every child inherits the choice
        self.plan.log_dir.mkdir(parents=True, exist_ok=True)
        self.redis = RedisServer(self.plan.log_dir / "redis")
        self.redis.start()
        store = self.base_settings.store
        if self.plan.use_minio:
            self.minio = MinioServer(self.plan.log_dir / "minio")
            self.minio.start(timeout_s=60)
            store = S3Settings(
                bucket="racer",
                endpoint_url=self.minio.endpoint_url,
                access_key_id=self.minio.access_key,
                secret_access_key=self.minio.secret_key,
            )
            S3Store(store).ensure_bucket()
        self.settings = ServiceSettings(redis=RedisSettings(url=self.redis.url, connect_timeout_s=10), store=store)
        return self.settings

    def _spawn(self, name: str, args: list[str]) -> None:
        log_path = self.plan.log_dir / f"{name}.log"
        with open(log_path, "ab") as log:
            self.children[name] = subprocess.Popen(
                [sys.executable, "-m", "racer.cli", *args],
                stdout=log,
                stderr=subprocess.STDOUT,
                env=service_environment(self.settings),
                preexec_fn=_die_with_parent,
            )

    def start_processes(self) -> None:
        plan = self.plan
        trainer_args = trainer_argv(plan)
        self._spawn("trainer", trainer_args)
        for worker_id in range(plan.run.num_workers):
            self._spawn(
                f"worker-{worker_id}",
                [
                    "rollout",
                    "--model-prefix",
                    plan.model_prefix,
                    "--worker-id",
                    str(worker_id),
                    "--seed",
                    str(plan.seed + worker_id),
                    *self._envs_args(),
                ],
            )
        if plan.viewer_port is not None:
            self._spawn(
                VIEWER,
                ["view", "--live", plan.model_prefix, "--host", plan.viewer_host, "--port", str(plan.viewer_port)],
            )

    def _envs_args(self) -> list[str]:
        return ["--envs", str(self.plan.envs_per_worker)] if self.plan.envs_per_worker else []

    def restart_worker(self, worker_id: int) -> None:
        self._spawn(
            f"worker-{worker_id}",
            [
                "rollout",
                "--model-prefix",
                self.plan.model_prefix,
                "--worker-id",
                str(worker_id),
                "--seed",
                str(self.plan.seed + worker_id + 1000),
                *self._envs_args(),
            ],
        )

    def stop_processes(self, interrupted: bool = False) -> None:
        """Interrupted: SIGTERM to all (the trainer writes its final checkpoint and .finished), killed after
        racer.local.supervisor's budget whatever Redis does; else the trainer has ended the run and the workers follow."""
        stop_children(self.children, trainer="trainer", at_once=interrupted, never_ending=(VIEWER,))

    def stop(self, interrupted: bool = True) -> None:
        self.stop_processes(interrupted)
        if self.minio:
            self.minio.stop(timeout_s=3)
        if self.redis:
            self.redis.stop(timeout_s=3)


def check_before_start(plan: LocalRunPlan, base_settings: ServiceSettings) -> None:
    """The trainer's preflight, here, before Redis or any process starts: a model that cannot train is refused with
    one message (file, field, fix). A clone source is checked too when the store is a local directory."""
    from racer.shared.user_errors import user_error_types
    from racer.trainer.preflight import preflight

    local_store = isinstance(base_settings.store, LocalStoreSettings) and not plan.use_minio
    try:
        report = preflight(
            plan.custom_files,
            plan.run,
            pretrained_prefix=plan.pretrained_prefix,
            store=open_store(base_settings.store) if local_store else None,
        )
    except user_error_types() as error:
        raise click.ClickException(str(error)) from error
    for warning in report.warnings:
        click.echo(f"note: {warning}", err=True)


def run_local_training(plan: LocalRunPlan, base_settings: ServiceSettings, on_evaluation=None) -> int:
    """Run until the trainer exits; returns its exit status. `on_evaluation(record)` may return True to stop early.
    Nothing starts unless the custom files pass the preflight."""
    check_before_start(plan, base_settings)
    run = LocalRun(plan, base_settings)
    started = time.monotonic()
    interrupted = False
    stopping = threading.Event()  # cuts the display's Redis retries short

    def request_stop(signum, frame):
        nonlocal interrupted
        interrupted = True
        stopping.set()

    previous = {sig: signal.signal(sig, request_stop) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        settings = run.start_services()
        click.echo(
            f"racer train: model {plan.model_prefix!r} in {open_store(settings.store).describe()}, "
            f"{plan.run.num_workers} workers ({', '.join(plan.run.worlds[: plan.run.num_workers])}) on track "
            f"{plan.run.track}; "
            f"logs in {plan.log_dir}"
        )
        run.start_processes()
        if plan.viewer_port is not None:
            click.echo(f"racer train: watch it live at {viewer_url(plan.viewer_host, plan.viewer_port)}")
        viewer_reported = False
        # The display never waits for Redis: short timeouts, and the supervisor says when Redis is down.
        channel = RunChannel(
            RedisLink(settings.redis, reconnect_budget_s=2.0, stop=stopping, operation_timeout_s=2.0), plan.model_prefix
        )
        display = ProgressDisplay(channel, plan.run.num_workers, started)
        supervisor = RunSupervisor(
            run.redis,
            run.children,
            run.restart_worker,
            num_workers=plan.run.num_workers,
            say=lambda text: click.echo(f"[{display._elapsed()}] {text}", err=True),
        )
        trainer = run.children["trainer"]
        while trainer.poll() is None and not interrupted:
            supervisor.check_processes()
            if supervisor.fatal_worker is not None:
                break
            if supervisor.redis_up:
                try:
                    for record in display.poll():
                        if on_evaluation is not None and on_evaluation(record):
                            interrupted = True
                    supervisor.check_heartbeats(channel.live_workers())
                except RedisUnavailableError:
                    pass  # a dead server shows in the next check_processes; a hung one keeps the display quiet
            viewer = run.children.get(VIEWER)
            if viewer is not None and viewer.poll() not in (None, 0) and not viewer_reported:
                viewer_reported = True  # training goes on without the page (e.g. the port is taken)
                click.echo(
                    f"the viewer exited with status {viewer.returncode}; training goes on without it (see "
                    f"{plan.log_dir / (VIEWER + '.log')})",
                    err=True,
                )
            time.sleep(1.0)
        if interrupted:
            click.echo("stopping: the trainer writes a final checkpoint and .finished ...", err=True)
            stopping.set()
        run.stop_processes(interrupted or supervisor.fatal_worker is not None)
        try:
            display.poll()  # the last iteration and evaluation lines, while Redis is still up
        except RedisUnavailableError:
            pass
        status = run.children["trainer"].returncode
        if supervisor.fatal_worker is not None:
            log_file = plan.log_dir / f"worker-{supervisor.fatal_worker}.log"
            error_lines = [line for line in log_file.read_text(errors="replace").splitlines() if line.strip()]
            start = max((i for i, line in enumerate(error_lines) if line.startswith("Error: ")), default=0)
            click.echo(f"racer train: the run stopped: {chr(10).join(error_lines[start:])[-3000:]}", err=True)
            return EXIT_RUN_CANNOT_GO_ON
        if status not in (0, None) and not interrupted:
            click.echo(f"trainer exited with status {status}; see {plan.log_dir / 'trainer.log'}:", err=True)
            click.echo((plan.log_dir / "trainer.log").read_text(errors="replace")[-3000:], err=True)
        return 0 if interrupted else (status or 0)
    finally:
        run.stop()
        for sig, handler in previous.items():
            signal.signal(sig, handler)
