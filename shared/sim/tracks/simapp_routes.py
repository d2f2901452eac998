"""What racer knows about every SimApp route file without having it: `tracks/simapp_routes.json`.

The SimApp ships 127 route files (`bundle/routes/<name>.npy` in aws-deepracer-community/deepracer-simapp). racer does
not carry them; it carries their facts (name, SHA-256, size, length, width, direction) and DeepRacer on AWS's track
list (aws-solutions/deepracer-on-aws `source/libs/config/src/data/tracks.json`: display name, directions,
description, difficulty), so every name is known on a fresh install and a route file is fetched, checked against its
hash, on first use (`racer.shared.sim.tracks.route_fetch`). `tools/simapp_route_catalogue.py` writes the file from a SimApp
checkout and a `tracks.json`; a test runs it again and compares byte for byte. This module reads the file only, so
that route lookup can use it without importing the simulator.
"""

from __future__ import annotations

import functools
import hashlib
import json
from dataclasses import dataclass
from pathlib import Path

from racer.shared.sim.tracks.droa_tracks import DroaTrack, parse_catalogue

CATALOGUE_NAME = "simapp_routes.json"
SIMAPP_REPOSITORY = "aws-deepracer-community/deepracer-simapp"
SIMAPP_ROUTES_FOLDER = "bundle/routes"
DROA_REPOSITORY = "aws-solutions/deepracer-on-aws"
DROA_TRACKS_PATH = "source/libs/config/src/data/tracks.json"


@dataclass(frozen=True)
class SimAppRoute:
    """One SimApp route file as the pinned commit has it."""

    name: str
    sha256: str
    size_bytes: int
    length_m: float
    width_m: float
    """Mean distance between the borders."""
    direction: str
    """`clockwise` or `counter-clockwise`: the way the rows run (an open route counts as counter-clockwise)."""
    waypoints: int

    @property
    def file_name(self) -> str:
        return f"{self.name}.npy"


@dataclass(frozen=True)
class RouteCatalogue:
    """The SimApp's routes at one commit and DeepRacer on AWS's tracks at one commit."""

    simapp_commit: str
    droa_commit: str
    routes: tuple[SimAppRoute, ...]
    droa_tracks: tuple[DroaTrack, ...]

    def route(self, name: str) -> SimAppRoute | None:
        return next((route for route in self.routes if route.name == name), None)


def file_sha256(path: Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def parse_route_catalogue(text: str, source: str) -> RouteCatalogue:
    try:
        document = json.loads(text)
    except json.JSONDecodeError as error:
        raise ValueError(f"{source}: line {error.lineno} column {error.colno}: {error.msg}") from None
    try:
        routes = tuple(
            SimAppRoute(
                name=str(row["name"]),
                sha256=str(row["sha256"]),
                size_bytes=int(row["size_bytes"]),
                length_m=float(row["length_m"]),
                width_m=float(row["width_m"]),
                direction=str(row["direction"]),
                waypoints=int(row["waypoints"]),
            )
            for row in document["routes"]
        )
        return RouteCatalogue(
            simapp_commit=str(document["simapp"]["commit"]),
            droa_commit=str(document["droa"]["commit"]),
            routes=routes,
            droa_tracks=parse_catalogue(document["droa_tracks"], source),
        )
    except (KeyError, TypeError) as error:
        raise ValueError(f"{source}: not a route catalogue (missing or malformed {error})") from None


def shipped_catalogue_path() -> Path:
    import racer.tracks

    return Path(racer.tracks.__file__).resolve().parent / CATALOGUE_NAME


@functools.cache
def shipped_catalogue() -> RouteCatalogue:
    """The catalogue racer ships (read once per process: it is package data and never changes while racer runs)."""
    path = shipped_catalogue_path()
    return parse_route_catalogue(path.read_text(encoding="utf-8"), str(path))
