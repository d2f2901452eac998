"""`racer track ...`: list, describe and plot routes."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import click
import numpy as np

from racer.shared.config import CACHE_HOME_VARIABLE, route_cache, route_library
from racer.shared.sim.scene.worlds import WORLD_NAMES
from racer.shared.sim.tracks.catalog import load_catalogue, resolve_track
from racer.shared.sim.tracks.droa_tracks import (
    CATALOGUE_FILE,
    CLOCKWISE,
    CLOCKWISE_SUFFIX,
    COUNTER_CLOCKWISE_SUFFIX,
    DroaTrack,
    read_catalogue,
)
from racer.shared.sim.tracks.route_fetch import (
    RouteFetchError,
    cached_route_path,
    catalogue_route_source,
    fetch_route,
    is_cached,
)
from racer.shared.sim.tracks.route_search import (
    ROUTE_SUFFIX,
    RouteNotFoundError,
    available_routes,
    find_route,
    search_folders,
)
from racer.shared.sim.tracks.simapp_routes import file_sha256, shipped_catalogue
from racer.shared.sim.tracks.track import Track, TrackError, read_route_file, route_facts
from racer.track.line_command import line_command


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


def _short_direction(direction: str) -> str:
    return "ccw" if direction == "counter-clockwise" else "cw"


def _short(directions: tuple[str, ...]) -> str:
    return ",".join("cw" if d == CLOCKWISE else "ccw" for d in directions)


def _droa_of(name: str, by_id: dict[str, DroaTrack]) -> DroaTrack | None:
    for suffix in ("", CLOCKWISE_SUFFIX, COUNTER_CLOCKWISE_SUFFIX):
        if suffix == "" or name.endswith(suffix):
            entry = by_id.get(name.removesuffix(suffix) if suffix else name)
            if entry is not None:
                return entry
    return None


def _local_route(name: str, folders: list[Path]) -> Path | None:
    """The route file on the search path (never fetched), or None."""
    try:
        return find_route(name, folders)
    except RouteNotFoundError:
        return None


def _route_cache_dir() -> Path:
    cache_dir = route_cache()
    if cache_dir is None:
        raise click.ClickException(f"no home folder to keep fetched tracks in; set {CACHE_HOME_VARIABLE}")
    return cache_dir


track_group.add_command(line_command)


@track_group.command("list")
@click.option(
    "--tracks-dir", type=click.Path(file_okay=False, path_type=Path), default=None, help="Folder of .npy routes."
)
@click.option(
    "--droa", "droa_only", is_flag=True, help="One line per DeepRacer-on-AWS track (its trackId, display name)."
)
@click.option("--search", "text", default=None, help="Only tracks whose name or DeepRacer-on-AWS name contains TEXT.")
def list_command(tracks_dir: Path | None, droa_only: bool, text: str | None) -> None:
    """Every track racer can drive: the routes on the search path (RACER_ROUTES_PATH, the route library, tracks/) and
    every SimApp route (fetched on first use). Tab-separated: name, DeepRacer-on-AWS name, length, width, directions
    (cw, ccw) and where the file is (a folder, `cached`, or `not fetched`)."""
    folders = [tracks_dir] if tracks_dir is not None else list(search_folders())
    catalogue = load_catalogue(folders if tracks_dir is not None else None)
    by_id = {t.track_id: t for t in catalogue}
    simapp = shipped_catalogue() if tracks_dir is None else None
    cache_dir = route_cache() if simapp is not None else None
    needle = text.lower() if text else None

    def wanted(*names: str) -> bool:
        return needle is None or any(needle in n.lower() for n in names if n)

    if droa_only:
        for entry in sorted(catalogue, key=lambda t: t.track_id.lower()):
            if not wanted(entry.track_id, entry.name):
                continue
            world = entry.world_name(entry.default_direction)
            local = _local_route(world, folders)
            known = simapp.route(world) if simapp is not None else None
            if local is not None:
                length_m, width_m, _, _ = route_facts(local)
                length, width = f"{length_m:.2f} m", f"{width_m:.2f} m wide"
            elif known is not None:
                length, width = f"{known.length_m:.2f} m", f"{known.width_m:.2f} m wide"
            else:
                length = f"{entry.length_m:.2f} m" if entry.length_m else "-"
                width = "no route installed"
            click.echo(f"{entry.track_id}\t{entry.name}\t{length}\t{width}\t{_short(entry.directions)}")
        return
    local_names = available_routes(folders)
    names = sorted(set(local_names) | ({route.name for route in simapp.routes} if simapp is not None else set()))
    for name in names:
        entry = _droa_of(name, by_id)
        if not wanted(name, entry.name if entry else ""):
            continue
        local = _local_route(name, folders) if name in local_names else None
        if local is not None:
            length, width, runs, _ = route_facts(local)
            where = str(local.parent)
        else:
            route = simapp.route(name)
            length, width, runs = route.length_m, route.width_m, route.direction
            where = "cached" if cache_dir is not None and is_cached(route, cache_dir) else "not fetched"
        directions = (
            _short(entry.directions) if entry is not None and entry.track_id == name else _short_direction(runs)
        )
        droa_name = entry.name if entry is not None else "-"
        click.echo(f"{name}\t{droa_name}\t{length:.2f} m\t{width:.2f} m wide\t{directions}\t{where}")


@track_group.command("fetch")
@click.argument("names", nargs=-1)
@click.option("--all", "fetch_all", is_flag=True, help="Every SimApp route (127 files, about 1.2 MB).")
@click.option("--verify", is_flag=True, help="Check every cached file against its SHA-256 instead of fetching.")
@direction_option
def fetch_command(names: tuple[str, ...], fetch_all: bool, verify: bool, direction: str | None) -> None:
    """Fetch SimApp routes into the cache ahead of time (for a machine that will train offline), from RACER_TRACKS_URL
    or the SimApp's repository; `--verify` re-checks what the cache holds. Names may be DeepRacer-on-AWS names."""
    catalogue = shipped_catalogue()
    cache_dir = _route_cache_dir()
    if verify:
        if names or fetch_all:
            raise click.UsageError("--verify checks the whole cache; give no names and no --all")
        bad = []
        checked = 0
        for route in catalogue.routes:
            path = cached_route_path(route, cache_dir)
            if path.is_file():
                checked += 1
                if not is_cached(route, cache_dir):
                    bad.append(route.name)
        for name in bad:
            click.echo(f"{name}: {cached_route_path(catalogue.route(name), cache_dir)} does not match its SHA-256")
        click.echo(f"{checked} cached route(s) in {cache_dir}, {len(bad)} bad")
        if bad:
            raise click.ClickException(f"remove the bad file(s) and fetch again: racer track fetch {' '.join(bad)}")
        return
    if fetch_all == bool(names):
        raise click.UsageError("give track names or --all")
    wanted = []
    for name in names:
        try:
            world = resolve_track(name, direction).world_name
        except ValueError as error:
            raise click.BadParameter(str(error), param_hint="NAMES") from error
        route = catalogue.route(world)
        if route is None:
            raise click.BadParameter(
                f"{name!r} is not a SimApp track (`racer track list` names them)", param_hint="NAMES"
            )
        wanted.append(route)
    source = catalogue_route_source()
    for index, route in enumerate(catalogue.routes if fetch_all else wanted, start=1):
        try:
            path = fetch_route(route, source)
        except RouteFetchError as error:
            raise click.ClickException(str(error)) from error
        click.echo(f"[{index}/{len(catalogue.routes) if fetch_all else len(wanted)}] {route.name}: {path}")


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
    simapp_route = shipped_catalogue().route(track.name)
    if simapp_route is not None and track.source:
        same = file_sha256(Path(track.source)) == simapp_route.sha256
        click.echo(
            f"file: {'the SimApp' if same else 'not the SimApp'}'s file (catalogue SHA-256 {simapp_route.sha256[:12]}...)"
        )
    droa = load_catalogue([tracks_dir] if tracks_dir is not None else None)
    entry = _droa_of(track.name, {t.track_id: t for t in droa})
    if entry is not None:
        click.echo(f"deepracer_on_aws: {entry.name} ({entry.track_id}, directions {_short(entry.directions)})")
        if entry.difficulty is not None:
            click.echo(f"difficulty: {entry.difficulty}")
        if entry.description:
            click.echo(f"description: {entry.description}")
    cache_dir = route_cache()
    if cache_dir is not None:
        click.echo(f"cache: {cache_dir}")


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

        from racer.track.top_view import render_top_view

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
