"""`racer track ...`: list, describe and plot routes."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import click
import numpy as np

from racer.shared.config import route_library
from racer.shared.sim.route_search import (
    CLOCKWISE_SUFFIX,
    COUNTER_CLOCKWISE_SUFFIX,
    ROUTE_SUFFIX,
    RouteNotFoundError,
    available_routes,
    find_route,
    search_folders,
)
from racer.shared.sim.track import Track, TrackError, read_route_file
from racer.shared.sim.track_catalog import (
    CATALOGUE_FILE,
    CLOCKWISE,
    DroaTrack,
    load_catalogue,
    read_catalogue,
    resolve_track,
)
from racer.shared.sim.worlds import WORLD_NAMES


def _load(name: str, tracks_dir: Path | None, direction: str | None = None) -> Track:
    try:
        folders = [tracks_dir] if tracks_dir is not None else None
        return Track.load(resolve_track(name, direction, folders).world_name, tracks_dir)
    except (TrackError, ValueError) as exc:
        raise click.ClickException(str(exc)) from exc


direction_option = click.option(
    "--direction",
    default=None,
    help="clockwise or counter-clockwise (a DeepRacer-on-AWS track's default when not given).",
)


@click.group("track")
def track_group() -> None:
    """Routes by name (RACER_ROUTES_PATH's folders, the route library, then the project's tracks/), by DeepRacer-on-AWS
    name, or any DeepRacer route file."""


def _route_facts(path: Path) -> tuple[float, float, str]:
    """(centre-line length m, mean width m, running direction) straight from the route file."""
    rows = read_route_file(path)
    center = rows[:, 0:2]
    length = float(np.hypot(*np.diff(center, axis=0).T).sum())
    width = float(np.hypot(*(rows[:, 2:4] - rows[:, 4:6]).T).mean())
    if not np.array_equal(rows[0], rows[-1]):
        return length, width, "ccw"  # an open route is driven forward as counter-clockwise (SimApp track_data.py)
    x, y = center[:, 0], center[:, 1]
    area = float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))
    return length, width, "ccw" if area > 0 else "cw"


def _short(directions: tuple[str, ...]) -> str:
    return ",".join("cw" if d == CLOCKWISE else "ccw" for d in directions)


def _droa_of(name: str, by_id: dict[str, DroaTrack]) -> DroaTrack | None:
    for suffix in ("", CLOCKWISE_SUFFIX, COUNTER_CLOCKWISE_SUFFIX):
        if suffix == "" or name.endswith(suffix):
            entry = by_id.get(name.removesuffix(suffix) if suffix else name)
            if entry is not None:
                return entry
    return None


@track_group.command("list")
@click.option(
    "--tracks-dir", type=click.Path(file_okay=False, path_type=Path), default=None, help="Folder of .npy routes."
)
@click.option(
    "--droa", "droa_only", is_flag=True, help="One line per DeepRacer-on-AWS track (its trackId, display name)."
)
@click.option("--search", "text", default=None, help="Only tracks whose name or DeepRacer-on-AWS name contains TEXT.")
def list_command(tracks_dir: Path | None, droa_only: bool, text: str | None) -> None:
    """Routes on the route search path (RACER_ROUTES_PATH, the route library, tracks/): name, DeepRacer-on-AWS
    name, length, width and directions (cw, ccw), tab-separated."""
    folders = [tracks_dir] if tracks_dir is not None else list(search_folders())
    catalogue = load_catalogue(folders)
    by_id = {t.track_id: t for t in catalogue}
    needle = text.lower() if text else None

    def wanted(*names: str) -> bool:
        return needle is None or any(needle in n.lower() for n in names if n)

    if droa_only:
        if not catalogue:
            raise click.ClickException(
                f"no DeepRacer-on-AWS track list ({CATALOGUE_FILE}) on the route search path; add one with "
                "`racer track import --droa tracks.json` (DeepRacer on AWS's source/libs/config/src/data/tracks.json)"
            )
        for entry in sorted(catalogue, key=lambda t: t.track_id.lower()):
            if not wanted(entry.track_id, entry.name):
                continue
            try:
                facts = _route_facts(find_route(entry.world_name(entry.default_direction), folders))
                length, width = f"{facts[0]:.2f} m", f"{facts[1]:.2f} m wide"
            except RouteNotFoundError:
                length = f"{entry.length_m:.2f} m" if entry.length_m else "-"
                width = "no route installed"
            click.echo(f"{entry.track_id}\t{entry.name}\t{length}\t{width}\t{_short(entry.directions)}")
        return
    for name in available_routes(folders):
        entry = _droa_of(name, by_id)
        if not wanted(name, entry.name if entry else ""):
            continue
        length, width, runs = _route_facts(find_route(name, folders))
        directions = _short(entry.directions) if entry is not None and entry.track_id == name else runs
        droa_name = entry.name if entry is not None else "-"
        click.echo(f"{name}\t{droa_name}\t{length:.2f} m\t{width:.2f} m wide\t{directions}")


@track_group.command("import")
@click.argument("sources", nargs=-1, type=click.Path(exists=True, path_type=Path))
@click.option(
    "--droa",
    "droa_file",
    type=click.Path(exists=True, dir_okay=False, path_type=Path),
    default=None,
    help="DeepRacer on AWS's tracks.json (source/libs/config/src/data/tracks.json): display names and directions.",
)
@click.option(
    "--to",
    "destination",
    type=click.Path(file_okay=False, path_type=Path),
    default=None,
    help="Folder to copy into (default: the route library, $RACER_DATA_HOME/routes or ~/.local/share/racer/routes).",
)
def import_command(sources: tuple[Path, ...], droa_file: Path | None, destination: Path | None) -> None:
    """Copy route files (.npy files, or folders of them such as the SimApp's bundle/routes) and DeepRacer on AWS's
    track list into the route library, so their names work as --track with no RACER_ROUTES_PATH."""
    if not sources and droa_file is None:
        raise click.UsageError("give route files or folders, and/or --droa tracks.json")
    target = destination or route_library()
    if target is None:
        raise click.ClickException("no home folder to put the route library in; give --to DIR or set RACER_DATA_HOME")
    files = [p for s in sources for p in (sorted(s.glob(f"*{ROUTE_SUFFIX}")) if s.is_dir() else [s])]
    for path in files:
        try:
            read_route_file(path)
        except TrackError as error:
            raise click.ClickException(str(error)) from error
    target.mkdir(parents=True, exist_ok=True)
    for path in files:
        shutil.copyfile(path, target / path.name)
    if files:
        click.echo(f"{len(files)} route file(s) -> {target}")
    if droa_file is not None:
        try:
            tracks = read_catalogue(droa_file)
        except ValueError as error:
            raise click.ClickException(str(error)) from error
        (target / CATALOGUE_FILE).write_text(json.dumps([t.to_compact() for t in tracks], indent=1) + "\n")
        click.echo(f"{len(tracks)} DeepRacer-on-AWS tracks -> {target / CATALOGUE_FILE}")


@track_group.command("show")
@click.argument("name")
@click.option("--tracks-dir", type=click.Path(file_okay=False, path_type=Path), default=None)
@direction_option
def show_command(name: str, tracks_dir: Path | None, direction: str | None) -> None:
    """Length, width, direction and waypoint count of a route (name, DeepRacer-on-AWS name or .npy path)."""
    track = _load(name, tracks_dir, direction)
    widths = np.hypot(*(track.inner_border - track.outer_border).T)
    lo = track.waypoints.reshape(-1, 3, 2).min(axis=(0, 1))
    hi = track.waypoints.reshape(-1, 3, 2).max(axis=(0, 1))
    click.echo(f"track: {track.name} ({track.source})")
    click.echo(f"length_m: {track.length_m:.4f}")
    click.echo(f"width_m: min {widths.min():.3f} mean {widths.mean():.3f} max {widths.max():.3f}")
    click.echo(f"waypoints: {track.num_waypoints}")
    click.echo(f"loop: {track.is_loop}")
    click.echo(f"direction: {'counter-clockwise' if track.is_ccw else 'clockwise'}")
    click.echo(f"extent_m: x {lo[0]:.2f}..{hi[0]:.2f}, y {lo[1]:.2f}..{hi[1]:.2f}")


@track_group.command("plot")
@click.argument("name")
@click.argument("out", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--tracks-dir", type=click.Path(file_okay=False, path_type=Path), default=None)
@click.option(
    "--rendered",
    "world",
    type=click.Choice(WORLD_NAMES),
    default=None,
    help="Draw what the simulator renders in this world, seen from above (PNG), instead of the diagram.",
)
def plot_command(name: str, out: Path, tracks_dir: Path | None, world: str | None) -> None:
    """Draw the route (borders, centre line, start and direction) to an image file."""
    if world is not None:
        from PIL import Image

        from racer.shared.sim.top_view import render_top_view

        out.parent.mkdir(parents=True, exist_ok=True)
        Image.fromarray(render_top_view(_load(name, tracks_dir), world)).save(out)
        click.echo(str(out))
        return
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    track = _load(name, tracks_dir)
    fig, ax = plt.subplots(figsize=(8, 6), dpi=100)
    ax.fill(track.outer_border[:, 0], track.outer_border[:, 1], color="0.25", zorder=0)
    ax.fill(track.inner_border[:, 0], track.inner_border[:, 1], color="white", zorder=1)
    ax.plot(track.inner_border[:, 0], track.inner_border[:, 1], color="k", lw=1)
    ax.plot(track.outer_border[:, 0], track.outer_border[:, 1], color="k", lw=1)
    ax.plot(track.center_line[:, 0], track.center_line[:, 1], "--", color="gold", lw=1)
    x0, y0 = track.center_line[0]
    x1, y1 = track.center_line[1]
    ax.annotate(
        "",
        xy=(x1 + 4 * (x1 - x0), y1 + 4 * (y1 - y0)),
        xytext=(x0, y0),
        arrowprops={"arrowstyle": "->", "color": "red"},
    )
    ax.plot([x0], [y0], "o", color="red")
    ax.set_aspect("equal")
    ax.set_title(f"{track.name}: {track.length_m:.2f} m")
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, bbox_inches="tight")
    plt.close(fig)
    click.echo(str(out))
