"""Fetch a SimApp route file on first use, check its SHA-256, keep it in the user's cache (pooch does the work).

The base address is a setting (`RACER_TRACKS_URL`, read in `racer.shared.config`): by default the SimApp's public
repository at the commit the catalogue was made from, `.../<commit>/bundle/routes/<name>.npy`. A mirror over HTTP(S),
a local folder of route files (a path or `file://`), or a SimApp checkout (a folder with `bundle/routes/`) serve as
well; pooch has no downloader for local files, so `copy_local_file` is one it accepts. A file whose hash differs is
refused and never reaches the cache (pooch downloads to a temporary file and moves it only after the check).
"""

from __future__ import annotations

import shutil
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any
from urllib.parse import unquote, urlparse

from racer.shared.config import CACHE_HOME_VARIABLE, route_cache, tracks_url
from racer.shared.sim.tracks.simapp_routes import (
    SIMAPP_REPOSITORY,
    SIMAPP_ROUTES_FOLDER,
    SimAppRoute,
    file_sha256,
    shipped_catalogue,
)


def default_tracks_url(simapp_commit: str) -> str:
    """The SimApp's own repository at the pinned commit, as raw files."""
    return f"https://raw.githubusercontent.com/{SIMAPP_REPOSITORY}/{simapp_commit}/{SIMAPP_ROUTES_FOLDER}/"


class RouteFetchError(RuntimeError):
    """A route could not be fetched or failed its check; the message names the track, the address and the ways out."""


@dataclass(frozen=True)
class RouteSource:
    """Where route files come from and where they are kept."""

    base_url: str
    """http(s)://..., file://..., or a local folder (route files, or a SimApp checkout with bundle/routes/)."""
    cache_dir: Path


def _local_folder(base_url: str) -> Path | None:
    """The folder a local base address names (a path or file://), None for a network address."""
    parsed = urlparse(base_url)
    if parsed.scheme == "file":
        folder = Path(unquote(parsed.path))
    elif parsed.scheme == "":
        folder = Path(base_url).expanduser()
    else:
        return None
    checkout_routes = folder / SIMAPP_ROUTES_FOLDER
    return checkout_routes if checkout_routes.is_dir() else folder


def route_address(base_url: str, file_name: str) -> str:
    """The address of one route file under the base address (a local path for a local base)."""
    folder = _local_folder(base_url)
    if folder is not None:
        return str(folder / file_name)
    return base_url.rstrip("/") + "/" + file_name


def copy_local_file(url: str, output_file: str | IO[bytes], pooch: Any, check_only: bool = False) -> bool | None:
    """A pooch downloader for a file on this machine (pooch's own ones speak HTTP, FTP, SFTP and DOI only)."""
    source = Path(url)
    if check_only:
        return source.is_file()
    if not source.is_file():
        raise FileNotFoundError(f"{source}: no such file")
    if isinstance(output_file, str):
        shutil.copyfile(source, output_file)
    else:
        with source.open("rb") as reader:
            shutil.copyfileobj(reader, output_file)
    return None


def cached_route_path(route: SimAppRoute, cache_dir: Path) -> Path:
    return Path(cache_dir) / route.file_name


def is_cached(route: SimAppRoute, cache_dir: Path) -> bool:
    """In the cache with the catalogue's hash (a file that does not match is not a cached route)."""
    path = cached_route_path(route, cache_dir)
    return path.is_file() and file_sha256(path) == route.sha256


def _ways_out(route: SimAppRoute) -> str:
    return (
        f"fetch it on a machine with network access (`racer track fetch {route.name}`) and copy the cache over, or "
        f"import the file yourself (`racer track import FOLDER`, for example a SimApp checkout's {SIMAPP_ROUTES_FOLDER})"
    )


def fetch_route(route: SimAppRoute, source: RouteSource) -> Path:
    """The route's file in the cache: used as it is when its hash matches, else fetched and checked first (pooch
    logs each download on stderr)."""
    import pooch
    import requests

    if is_cached(route, source.cache_dir):
        return cached_route_path(route, source.cache_dir)
    address = route_address(source.base_url, route.file_name)
    local = _local_folder(source.base_url) is not None
    try:
        fetched = pooch.retrieve(
            address,
            known_hash=f"sha256:{route.sha256}",
            fname=route.file_name,
            path=source.cache_dir,
            downloader=copy_local_file if local else None,
            progressbar=False,
        )
    except (requests.exceptions.ConnectionError, requests.exceptions.Timeout) as error:
        raise RouteFetchError(
            f"track {route.name}: cannot reach {address} ({type(error).__name__}). No network? Either {_ways_out(route)}"
        ) from None
    except requests.exceptions.HTTPError as error:
        raise RouteFetchError(f"track {route.name}: {address} answered {error}. Either {_ways_out(route)}") from None
    except FileNotFoundError as error:
        raise RouteFetchError(
            f"track {route.name}: {error} (RACER_TRACKS_URL={source.base_url}). Either {_ways_out(route)}"
        ) from None
    except ValueError as error:
        # pooch's hash check: the temporary file is removed, nothing reaches the cache.
        raise RouteFetchError(
            f"track {route.name}: the file at {address} is not the SimApp's {route.file_name} "
            f"(expected SHA-256 {route.sha256}); refused, not cached ({error})"
        ) from None
    return Path(fetched)


def catalogue_route_source() -> RouteSource:
    """The settings' source: RACER_TRACKS_URL (or the SimApp at the catalogue's commit) into the user's cache."""
    cache_dir = route_cache()
    if cache_dir is None:
        raise RouteFetchError(f"no home folder to keep fetched tracks in; set {CACHE_HOME_VARIABLE}")
    return RouteSource(tracks_url() or default_tracks_url(shipped_catalogue().simapp_commit), cache_dir)


def fetch_catalogue_route(name: str) -> Path | None:
    """The cached (fetched on first use) file of a SimApp route by name; None when the catalogue has no such name."""
    route = shipped_catalogue().route(name)
    if route is None:
        return None
    return fetch_route(route, catalogue_route_source())
