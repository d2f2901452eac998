"""Deployment settings: where Redis and the object store are.

This is the only module that reads environment variables: everything else receives the values built here, so a
test or a subprocess can be configured explicitly. The exceptions are `shared/sim/scene/gl.py`, which chooses `MUJOCO_GL`
before MuJoCo loads, and launchers that copy their environment into a child process's
(tests/foundation/test_environment_reads.py holds the list).

| variable | meaning | default |
|---|---|---|
| `RACER_REDIS_URL` | Redis URL | `redis://127.0.0.1:6379/0` |
| `RACER_STORE` | `s3://bucket` or a local directory | `./racer-data` |
| `S3_ENDPOINT_URL` | S3 endpoint (MinIO), as in DeepRacer's `S3_ENDPOINT_URL` | unset (AWS) |
| `AWS_ACCESS_KEY_ID`, `AWS_SECRET_ACCESS_KEY`, `AWS_SESSION_TOKEN`, `AWS_DEFAULT_REGION` | S3 credentials and region | boto3's own chain, region `us-east-1` |
| `RACER_CONNECT_TIMEOUT_S` | how long to try reaching Redis or S3 before giving up | `10` |
| `MAX_MEMORY_STEPS` | trainer: transitions one iteration trains on, as the SimApp's variable (0 = no cap) | DeepRacer's: 10000 shallow network, 3000 others |
| `RACER_ROUTES_PATH` | folders of DeepRacer route files (`<WORLD_NAME>.npy`), `:`-separated, searched in order before the route library and racer's `tracks/` | unset |
| `RACER_DATA_HOME` | racer's per-user data folder; its `routes/` is the route library `racer track import` fills | `$XDG_DATA_HOME/racer`, else `~/.local/share/racer` |
| `RACER_DEEPRACER_DATA` | a folder of DeepRacer's own files (routes, models, reward functions, simtraces) that benchmarks compare against (`python -m benchmarks ... --data`) | unset |
| `RACER_TRACKS_URL` | where SimApp route files are fetched from on first use (http(s)://, file://, a folder, a SimApp checkout) | the SimApp's repository at the catalogue's commit |
| `RACER_CACHE_HOME` | racer's per-user cache; fetched route files are kept in its `routes/`, computed racing lines in its `lines/` | `$XDG_CACHE_HOME/racer`, else `~/.cache/racer` |
| `RACER_OVERLAP` | workers keep playing while the trainer updates (`--overlap`'s default: True/1 or False/0/empty) | empty: strict |
| `RACER_GENERATION` | the DeepRacer simulator to stand in for, its look and car together (`--generation`: 2019, simapp5, simapp6) | `simapp6` |
| `DR_DIR` | the DeepRacer-for-Cloud folder (its `bin/activate.sh` exports it): `--drfc` given a run.env reads its system.env, worker-N.env and custom_files/ there, as DRfC does | unset: run.env's folder |
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

DEFAULT_REDIS_URL = "redis://127.0.0.1:6379/0"
DEFAULT_LOCAL_STORE = "./racer-data"


@dataclass(frozen=True)
class RedisSettings:
    url: str = DEFAULT_REDIS_URL
    connect_timeout_s: float = 10.0
    """Total time budget for reaching the server (retries with backoff inside it)."""


@dataclass(frozen=True)
class S3Settings:
    bucket: str
    endpoint_url: str | None = None
    access_key_id: str | None = None
    secret_access_key: str | None = None
    session_token: str | None = None
    """For temporary credentials (STS, SSO): AWS_SESSION_TOKEN."""
    region: str = "us-east-1"
    connect_timeout_s: float = 10.0


@dataclass(frozen=True)
class LocalStoreSettings:
    root: Path


StoreSettings = S3Settings | LocalStoreSettings


@dataclass(frozen=True)
class ServiceSettings:
    redis: RedisSettings
    store: StoreSettings


def parse_store_location(location: str, environ: Mapping[str, str], connect_timeout_s: float) -> StoreSettings:
    """`s3://bucket` selects S3 (credentials and endpoint from the environment); anything else is a directory."""
    if location.startswith("s3://"):
        bucket = location.removeprefix("s3://").strip("/")
        if not bucket or "/" in bucket:
            raise ValueError(f"RACER_STORE={location!r}: expected s3://<bucket> with no key prefix")
        return S3Settings(
            bucket=bucket,
            endpoint_url=environ.get("S3_ENDPOINT_URL") or None,
            access_key_id=environ.get("AWS_ACCESS_KEY_ID") or None,
            secret_access_key=environ.get("AWS_SECRET_ACCESS_KEY") or None,
            session_token=environ.get("AWS_SESSION_TOKEN") or None,
            region=environ.get("AWS_DEFAULT_REGION") or environ.get("AWS_REGION") or "us-east-1",
            connect_timeout_s=connect_timeout_s,
        )
    return LocalStoreSettings(root=Path(location).expanduser().resolve())


def _connect_timeout_s(env: Mapping[str, str]) -> float:
    return float(env.get("RACER_CONNECT_TIMEOUT_S", "10"))


def settings_from_env(environ: Mapping[str, str] | None = None) -> ServiceSettings:
    env = os.environ if environ is None else environ
    timeout_s = _connect_timeout_s(env)
    return ServiceSettings(
        redis=RedisSettings(url=env.get("RACER_REDIS_URL", DEFAULT_REDIS_URL), connect_timeout_s=timeout_s),
        store=parse_store_location(env.get("RACER_STORE", DEFAULT_LOCAL_STORE), env, timeout_s),
    )


def store_settings_at(location: str, environ: Mapping[str, str] | None = None) -> StoreSettings:
    """The store a command names itself (`s3://bucket` or a folder) instead of RACER_STORE; an S3 store's endpoint,
    keys and connect timeout come from the environment as RACER_STORE's do."""
    env = os.environ if environ is None else environ
    return parse_store_location(location, env, _connect_timeout_s(env))


def max_memory_steps_from_env(environ: Mapping[str, str] | None = None) -> int | None:
    """DeepRacer's MAX_MEMORY_STEPS for the trainer: a whole number (0 = no cap), or None when unset."""
    env = os.environ if environ is None else environ
    raw = env.get("MAX_MEMORY_STEPS", "").strip()
    if not raw:
        return None
    if not raw.isdigit():
        raise ValueError(f"MAX_MEMORY_STEPS={raw!r}: expected a whole number of steps (0 = no cap)")
    return int(raw)


ROUTES_PATH_VARIABLE = "RACER_ROUTES_PATH"


def route_folders(environ: Mapping[str, str] | None = None) -> tuple[Path, ...]:
    """The folders of RACER_ROUTES_PATH (os.pathsep-separated, empty entries skipped), in the order given."""
    env = os.environ if environ is None else environ
    raw = env.get(ROUTES_PATH_VARIABLE, "")
    return tuple(Path(part).expanduser().resolve() for part in raw.split(os.pathsep) if part.strip())


DATA_HOME_VARIABLE = "RACER_DATA_HOME"


def route_library(environ: Mapping[str, str] | None = None) -> Path | None:
    """The per-user route library (`racer track import` copies route files and DeepRacer-on-AWS's track list there):
    `$RACER_DATA_HOME/routes`, else `$XDG_DATA_HOME/racer/routes`, else `$HOME/.local/share/racer/routes`; None when
    the environment names no home at all."""
    env = os.environ if environ is None else environ
    if env.get(DATA_HOME_VARIABLE, "").strip():
        base = Path(env[DATA_HOME_VARIABLE])
    elif env.get("XDG_DATA_HOME", "").strip():
        base = Path(env["XDG_DATA_HOME"]) / "racer"
    elif env.get("HOME", "").strip():
        base = Path(env["HOME"]) / ".local" / "share" / "racer"
    else:
        return None
    return (base.expanduser() / "routes").resolve()


TRACKS_URL_VARIABLE = "RACER_TRACKS_URL"
CACHE_HOME_VARIABLE = "RACER_CACHE_HOME"


def tracks_url(environ: Mapping[str, str] | None = None) -> str | None:
    """Where SimApp route files are fetched from (RACER_TRACKS_URL: http(s)://, file://, a folder or a SimApp
    checkout); None: the SimApp's repository at the commit racer's catalogue names."""
    env = os.environ if environ is None else environ
    return env.get(TRACKS_URL_VARIABLE, "").strip() or None


def _cache_folder(name: str, environ: Mapping[str, str] | None) -> Path | None:
    """`name` in racer's per-user cache: `$RACER_CACHE_HOME`, else `$XDG_CACHE_HOME/racer`, else `$HOME/.cache/racer`;
    None when the environment names no home at all."""
    env = os.environ if environ is None else environ
    if env.get(CACHE_HOME_VARIABLE, "").strip():
        base = Path(env[CACHE_HOME_VARIABLE])
    elif env.get("XDG_CACHE_HOME", "").strip():
        base = Path(env["XDG_CACHE_HOME"]) / "racer"
    elif env.get("HOME", "").strip():
        base = Path(env["HOME"]) / ".cache" / "racer"
    else:
        return None
    return (base.expanduser() / name).resolve()


def route_cache(environ: Mapping[str, str] | None = None) -> Path | None:
    """The folder fetched route files are kept in: `$RACER_CACHE_HOME/routes`, else `$XDG_CACHE_HOME/racer/routes`,
    else `$HOME/.cache/racer/routes`; None when the environment names no home at all."""
    return _cache_folder("routes", environ)


def line_cache(environ: Mapping[str, str] | None = None) -> Path | None:
    """The folder computed racing lines are kept in (`racer track line`): `lines/` beside `route_cache`'s `routes/`;
    None when the environment names no home at all."""
    return _cache_folder("lines", environ)


DEEPRACER_DATA_VARIABLE = "RACER_DEEPRACER_DATA"


def deepracer_data(environ: Mapping[str, str] | None = None) -> Path | None:
    """The folder of DeepRacer's own files some benchmarks compare against (RACER_DEEPRACER_DATA); None when unset."""
    env = os.environ if environ is None else environ
    raw = env.get(DEEPRACER_DATA_VARIABLE, "").strip()
    return Path(raw).expanduser().resolve() if raw else None


GENERATION_VARIABLE = "RACER_GENERATION"


def generation_name(environ: Mapping[str, str] | None = None) -> str | None:
    """The DeepRacer generation RACER_GENERATION names (the default of `--generation`); None when unset, which
    means racer's default generation (`racer.shared.sim.generations.catalog.DEFAULT_GENERATION`)."""
    env = os.environ if environ is None else environ
    return env.get(GENERATION_VARIABLE, "").strip() or None


OVERLAP_VARIABLE = "RACER_OVERLAP"
_TRUE_WORDS = ("true", "1", "yes", "on")
_FALSE_WORDS = ("", "false", "0", "no", "off")


def overlap_setting(environ: Mapping[str, str] | None = None) -> bool:
    """RACER_OVERLAP (the default of `--overlap`): True, 1, yes or on overlaps; empty, False, 0, no or off keeps
    DeepRacer's strict alternation; anything else is an error naming the variable."""
    env = os.environ if environ is None else environ
    raw = env.get(OVERLAP_VARIABLE, "").strip()
    if raw.lower() in _TRUE_WORDS:
        return True
    if raw.lower() in _FALSE_WORDS:
        return False
    raise ValueError(f"{OVERLAP_VARIABLE}={raw!r}: expected True or False (or 1 / 0, empty for False)")


DRFC_DIR_VARIABLE = "DR_DIR"


def drfc_dir(environ: Mapping[str, str] | None = None) -> Path | None:
    """The DeepRacer-for-Cloud folder DR_DIR names (DRfC's activate.sh exports it as its own folder); None when
    unset, and then `--drfc` given a run.env reads the files beside it."""
    env = os.environ if environ is None else environ
    raw = env.get(DRFC_DIR_VARIABLE, "").strip()
    return Path(raw).expanduser().absolute() if raw else None
