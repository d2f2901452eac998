"""`racer track ...`: list, describe and plot routes."""

from __future__ import annotations

from pathlib import Path

import click
import numpy as np

from racer.shared.sim.track import Track, TrackError, available_tracks
from racer.shared.sim.worlds import WORLD_NAMES


def _load(name: str, tracks_dir: Path | None) -> Track:
    try:
        return Track.load(name, tracks_dir)
    except TrackError as exc:
        raise click.ClickException(str(exc)) from exc


@click.group("track")
def track_group() -> None:
    """Routes by name (RACER_ROUTES_PATH's folders, then the project's tracks/) or any DeepRacer route file."""


@track_group.command("list")
@click.option(
    "--tracks-dir", type=click.Path(file_okay=False, path_type=Path), default=None, help="Folder of .npy routes."
)
def list_command(tracks_dir: Path | None) -> None:
    """Names of the routes on the route search path (RACER_ROUTES_PATH, then tracks/), with length and width."""
    for name in available_tracks(tracks_dir):
        track = _load(name, tracks_dir)
        widths = np.hypot(*(track.inner_border - track.outer_border).T)
        click.echo(f"{name}\t{track.length_m:.2f} m\t{widths.mean():.2f} m wide\t{track.num_waypoints} waypoints")


@track_group.command("show")
@click.argument("name")
@click.option("--tracks-dir", type=click.Path(file_okay=False, path_type=Path), default=None)
def show_command(name: str, tracks_dir: Path | None) -> None:
    """Length, width, direction and waypoint count of a route (name or .npy path)."""
    track = _load(name, tracks_dir)
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
