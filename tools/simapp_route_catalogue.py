"""Write racer's catalogue of the SimApp's route files (`tracks/simapp_routes.json`) from a SimApp checkout.

    python tools/simapp_route_catalogue.py SIMAPP_CHECKOUT_OR_ROUTES_FOLDER DROA_TRACKS_JSON \\
        --simapp-commit COMMIT --droa-commit COMMIT [--out tracks/simapp_routes.json]

SIMAPP_CHECKOUT_OR_ROUTES_FOLDER is a checkout of aws-deepracer-community/deepracer-simapp (its `bundle/routes/` is
read) or a folder of its route files; DROA_TRACKS_JSON is aws-solutions/deepracer-on-aws's
`source/libs/config/src/data/tracks.json`. The commits are recorded in the catalogue: the SimApp's one is where racer
fetches route files from by default, so pin the one the folder was taken from. The output is deterministic: running
this again on the same files gives the same bytes (a test checks the shipped file that way).
"""

from __future__ import annotations

import json
from pathlib import Path

import click

from racer.shared.sim.tracks.droa_tracks import parse_catalogue
from racer.shared.sim.tracks.simapp_routes import (
    DROA_REPOSITORY,
    DROA_TRACKS_PATH,
    SIMAPP_REPOSITORY,
    SIMAPP_ROUTES_FOLDER,
    SimAppRoute,
    file_sha256,
    shipped_catalogue_path,
)
from racer.shared.sim.tracks.track import route_facts


def describe_route(path: Path) -> SimAppRoute:
    length_m, width_m, direction, rows = route_facts(path)
    return SimAppRoute(
        name=path.stem,
        sha256=file_sha256(path),
        size_bytes=path.stat().st_size,
        length_m=length_m,
        width_m=width_m,
        direction=direction,
        waypoints=rows,
    )


def catalogue_text(routes_dir: Path, droa_tracks_json: Path, simapp_commit: str, droa_commit: str) -> str:
    """The catalogue file for a folder of route files and DeepRacer on AWS's `tracks.json`, deterministic to the byte
    (sorted names, lengths to the millimetre)."""
    droa_rows = json.loads(Path(droa_tracks_json).read_text(encoding="utf-8-sig"))
    droa = parse_catalogue(droa_rows, str(droa_tracks_json))
    routes = [describe_route(path) for path in sorted(Path(routes_dir).glob("*.npy"), key=lambda p: p.stem)]
    if not routes:
        raise ValueError(f"{routes_dir}: no route files (*.npy)")
    document = {
        "simapp": {"repository": SIMAPP_REPOSITORY, "commit": simapp_commit, "folder": SIMAPP_ROUTES_FOLDER},
        "droa": {"repository": DROA_REPOSITORY, "commit": droa_commit, "path": DROA_TRACKS_PATH},
        "routes": [
            {
                "name": route.name,
                "sha256": route.sha256,
                "size_bytes": route.size_bytes,
                "length_m": round(route.length_m, 3),
                "width_m": round(route.width_m, 3),
                "direction": route.direction,
                "waypoints": route.waypoints,
            }
            for route in routes
        ],
        "droa_tracks": [
            {
                "trackId": track.track_id,
                "name": track.name,
                "directions": list(track.directions),
                "defaultDirection": track.default_direction,
                "length": track.length_m,
                "description": track.description,
                "difficulty": track.difficulty,
            }
            for track in sorted(droa, key=lambda t: t.track_id)
        ],
    }
    return json.dumps(document, indent=1, ensure_ascii=False) + "\n"


@click.command()
@click.argument("simapp", type=click.Path(exists=True, file_okay=False, path_type=Path))
@click.argument("droa_tracks", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option("--simapp-commit", required=True, help="The SimApp commit the route files come from.")
@click.option("--droa-commit", required=True, help="The deepracer-on-aws commit tracks.json comes from.")
@click.option("--out", type=click.Path(dir_okay=False, path_type=Path), default=None, help="Default: racer's own.")
def main(simapp: Path, droa_tracks: Path, simapp_commit: str, droa_commit: str, out: Path | None) -> None:
    routes = simapp / SIMAPP_ROUTES_FOLDER if (simapp / SIMAPP_ROUTES_FOLDER).is_dir() else simapp
    target = out or shipped_catalogue_path()
    target.write_text(catalogue_text(routes, droa_tracks, simapp_commit, droa_commit), encoding="utf-8")
    click.echo(f"{target}: {len(list(routes.glob('*.npy')))} routes")


if __name__ == "__main__":
    main()
