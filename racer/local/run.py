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
from datetime import datetime
from pathlib import Path

import click

from racer.local.services import PROJECT_ROOT, MinioServer, RedisServer, _die_with_parent
from racer.local.supervisor import RunSupervisor, stop_children
from racer.rollout_worker.batched_rollout import DEFAULT_ENVS_PER_WORKER, DEFAULT_WORKERS
from racer.rollout_worker.main import EXIT_RUN_CANNOT_GO_ON
from racer.shared.config import LocalStoreSettings, RedisSettings, S3Settings, ServiceSettings, settings_from_env
from racer.shared.redis_connection import RedisLink, RedisUnavailableError
from racer.shared.sim.config import DEFAULT_TRACK
from racer.shared.sim.gl import ensure_gl_backend
from racer.shared.sim.race_cli import race_option_args, race_options, race_params_from_options
from racer.shared.sim.track_option import direction_option
from racer.shared.sim.worlds import WORLD_NAMES as WORLDS
from racer.shared.store import S3Store, open_store
from racer.shared.transport.channels import RunChannel
from racer.trainer.run_options import trainer_arguments, trainer_run_options


@dataclass(frozen=True)
class LocalRunPlan:
    model_prefix: str
    custom_files: Path
    num_workers: int
    worlds: tuple[str, ...]
    track: str
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
    race_params: tuple[tuple[str, str], ...] = ()
    """RACE_TYPE and obstacle / bot-car training_params keys for every worker (`--race-type`, `--race-param`)."""


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
        trainer_args = [
            "trainer",
            "--model-prefix",
            plan.model_prefix,
            "--custom-files",
            str(plan.custom_files),
            "--workers",
            str(plan.num_workers),
            "--track",
            plan.track,
            "--worlds",
            ",".join(plan.worlds),
            "--seed",
            str(plan.seed),
        ]
        if plan.max_episodes is not None:
            trainer_args += ["--max-episodes", str(plan.max_episodes)]
        if plan.max_minutes is not None:
            trainer_args += ["--max-minutes", str(plan.max_minutes)]
        if plan.pretrained_prefix:
            trainer_args += [
                "--pretrained-prefix",
                plan.pretrained_prefix,
                "--pretrained-checkpoint",
                plan.pretrained_checkpoint,
            ]
        trainer_args += race_option_args(plan.race_params) + list(plan.trainer_options)
        self._spawn("trainer", trainer_args)
        for worker_id in range(plan.num_workers):
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


class ProgressDisplay:
    """Prints one line per finished iteration and per evaluation, plus a status line while waiting."""

    def __init__(self, channel: RunChannel, num_workers: int, started: float, echo=click.echo):
        self.channel = channel
        self.num_workers = num_workers
        self.started = started
        self.echo = echo
        self.iteration_id = "0"
        self.evaluation_id = "0"
        self.last_status = 0.0
        self.seen_workers: set[int] = set()

    def poll(self) -> list[dict]:
        """Print what is new; return the new evaluation records (benchmarks watch them)."""
        for stream_id, record in self.channel.read_records("iterations", self.iteration_id):
            self.iteration_id = stream_id
            worlds = "  ".join(
                f"{world}: R={stats['mean_reward']:.1f} P={stats['mean_progress']:.0f}%"
                for world, stats in sorted(record["worlds"].items())
            )
            self.echo(
                f"[{self._elapsed()}] iteration {record['iteration']:>3}  episodes {record['episodes']:>3}  "
                f"steps {record['env_steps_total']:>8}  reward {record['mean_reward']:7.2f}  "
                f"progress {record['mean_progress']:5.1f}%  complete {record['completion_rate']:4.0%}  "
                f"{record['experience_steps_per_s']:6.0f} steps/s  | {worlds}"
            )
        evaluations = []
        for stream_id, record in self.channel.read_records("evaluations", self.evaluation_id):
            self.evaluation_id = stream_id
            evaluations.append(record)
            self.echo(
                f"[{self._elapsed()}] evaluation of {record['checkpoint']}: {record['laps_completed']}/{record['trials']} laps, "
                f"mean progress {record['mean_progress']:.1f}%"
                + (f", best lap {record['best_lap_time_s']:.2f} s" if record.get("best_lap_time_s") else "")
            )
        if time.monotonic() - self.last_status > 30:
            self.last_status = time.monotonic()
            live = self.channel.live_workers()
            self.seen_workers.update(live)
            states = ", ".join(f"w{i}:{self._worker_state(i, live)}" for i in range(self.num_workers))
            self.echo(f"[{self._elapsed()}] workers {states}", err=True)
        return evaluations

    def _worker_state(self, worker_id: int, live: dict[int, dict]) -> str:
        """Its heartbeat's state; "starting" until its first heartbeat (importing, building its envs)."""
        if worker_id in live:
            return live[worker_id].get("state", "?")
        return "DOWN" if worker_id in self.seen_workers else "starting"

    def _elapsed(self) -> str:
        seconds = int(time.monotonic() - self.started)
        return f"{seconds // 60:02d}:{seconds % 60:02d}"


def check_before_start(plan: LocalRunPlan, base_settings: ServiceSettings) -> None:
    """The trainer's preflight, here, before Redis or any process starts: a model that cannot train is refused with
    one message (file, field, fix). A clone source is checked too when the store is a local directory."""
    from racer.shared.user_errors import user_error_types
    from racer.trainer.preflight import preflight

    local_store = isinstance(base_settings.store, LocalStoreSettings) and not plan.use_minio
    try:
        report = preflight(
            plan.custom_files,
            plan.num_workers,
            plan.track,
            plan.worlds,
            pretrained_prefix=plan.pretrained_prefix,
            store=open_store(base_settings.store) if local_store else None,
            race_params=plan.race_params,
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
            f"{plan.num_workers} workers ({', '.join(plan.worlds[: plan.num_workers])}) on track {plan.track}; "
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
        display = ProgressDisplay(channel, plan.num_workers, started)
        supervisor = RunSupervisor(
            run.redis,
            run.children,
            run.restart_worker,
            num_workers=plan.num_workers,
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


@click.command(name="train")
@click.option("--model-prefix", default=None, help="Model name (store prefix). Default: racer-<date>-<time>.")
@click.option(
    "--custom-files",
    type=click.Path(exists=True, file_okay=False, path_type=Path),
    default=PROJECT_ROOT / "custom_files",
    show_default=True,
    help="Folder with reward_function.py, model_metadata.json, hyperparameters.json.",
)
@click.option(
    "--workers",
    "num_workers",
    type=click.IntRange(1, 32),
    default=DEFAULT_WORKERS,
    show_default=True,
    help="Rollout workers, one per world in turn. The default is the same on every machine, so a seed gives the "
    "same kind of run everywhere; on more than 4 cores raise it to use them (the run then plays its episodes on "
    "other workers and so differs, though it learns the same way).",
)
@click.option(
    "--envs",
    "envs_per_worker",
    type=click.IntRange(1, 64),
    default=DEFAULT_ENVS_PER_WORKER,
    show_default=True,
    help="Envs each worker steps at once, all actions from one batched forward pass.",
)
@click.option("--worlds", default=",".join(WORLDS), show_default=True, help="Worlds given to workers in turn.")
@click.option("--track", default=DEFAULT_TRACK, show_default=True, help="Track name in tracks/ or a .npy route path.")
@click.option(
    "--max-episodes",
    type=int,
    default=None,
    help="Stop after this many training episodes (default: hyperparameters' term_cond_max_episodes).",
)
@click.option("--max-minutes", type=float, default=None, help="Stop after this much wall time.")
@click.option("--minio", "use_minio", is_flag=True, help="Store in a local MinIO server instead of a directory.")
@click.option("--pretrained-prefix", default=None, help="Clone: start from this model's checkpoint.")
@click.option("--pretrained-checkpoint", type=click.Choice(["last", "best"]), default="last", show_default=True)
@click.option("--seed", type=int, default=0, show_default=True)
@click.option(
    "--viewer-port",
    type=click.IntRange(0, 65535),
    default=8100,
    show_default=True,
    help="Port of the live web page (camera streams, curves, evaluations); 0: no page.",
)
@click.option(
    "--viewer-host",
    default="127.0.0.1",
    show_default=True,
    help="Address the page listens on; the default is reachable from this machine only.",
)
@trainer_run_options
@race_options
@direction_option
def train_command(
    model_prefix,
    custom_files,
    num_workers,
    envs_per_worker,
    worlds,
    track,
    max_episodes,
    max_minutes,
    use_minio,
    pretrained_prefix,
    pretrained_checkpoint,
    seed,
    viewer_port,
    viewer_host,
    precision,
    car_profile,
    dynamics_randomization,
    race_type,
    race_param,
) -> None:
    """Train with the embedded default: Redis, store, trainer and rollout workers as local processes."""
    base_settings = settings_from_env()
    model_prefix = model_prefix or datetime.now().strftime("racer-%Y%m%d-%H%M%S")
    store_root = base_settings.store.root if isinstance(base_settings.store, LocalStoreSettings) else Path("racer-data")
    plan = LocalRunPlan(
        model_prefix=model_prefix,
        custom_files=custom_files.resolve(),
        num_workers=num_workers,
        worlds=tuple(w.strip() for w in worlds.split(",") if w.strip()),
        track=track,
        max_episodes=max_episodes,
        max_minutes=max_minutes,
        use_minio=use_minio,
        log_dir=Path(store_root) / ".runs" / model_prefix,
        seed=seed,
        pretrained_prefix=pretrained_prefix,
        pretrained_checkpoint=pretrained_checkpoint,
        viewer_host=viewer_host,
        viewer_port=viewer_port or None,
        race_params=race_params_from_options(race_type, race_param),
        envs_per_worker=envs_per_worker,
        trainer_options=trainer_arguments(precision, car_profile, dynamics_randomization),
    )
    sys.exit(run_local_training(plan, base_settings))
