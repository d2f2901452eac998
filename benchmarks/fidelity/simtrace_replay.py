"""`python -m benchmarks fidelity`: open-loop replay of real DeepRacer simtraces through racer's car, per speed band.

For segments of real episodes (console 2022 and DeepRacer-for-Cloud runs on re:Invent 2018), the car starts at a
logged pose with the logged speed and yaw rate, receives the logged actions for the logged time of each step, and
its pose after 1 s and 2 s is compared with the log. No closed loop: the errors are the car model's alone.

Timing in a simtrace (SimApp v4+): row k's pose is read before step k's action acts; the row's `tstamp` is taken
after that step's physics. So pose k holds at `tstamp[k-1]`, and action k acts from pose k to pose k+1. Every row
is replayed for DeepRacer's nominal 1/15 s (16 substeps of 1/240 s), not for its logged tstamp difference: at a
held speed the logged step lengths explain only ≈ 11 % of the spread of the distance per row, and held out the
nominal step replays better in every band (research/replay_limits and research/tyre_fit). The logged tstamps still pick
the poses compared after 1 s and 2 s. The starting velocity and yaw rate are central differences of the logged
car-origin track around the start pose (poses 1/15 s apart); the steering hinges start at the previous row's
command. Segments contain only `in_progress` rows (no resets).
"""

from __future__ import annotations

import json
import math
import sys
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

import click
import numpy as np

from benchmarks.deepracer_data import REINVENT_2018_ROUTE, data_folder, data_option
from racer.shared.deepracer.simtrace import read_simtrace
from racer.shared.sim.car.dynamics import CAR_DYNAMICS, SIMTRACE_FIT_DYNAMICS, CarDynamics
from racer.shared.sim.car.vehicle import STEERING_JOINTS, WHEEL_NAMES, WHEEL_RADIUS_M, Car, clip_command
from racer.shared.sim.config import EnvConfig
from racer.shared.sim.env import DeepRacerEnv
from racer.shared.sim.generations.catalog import GENERATION_NAMES, GENERATIONS
from racer.shared.sim.scene._mujoco import mujoco
from racer.shared.sim.tracks.track import Track

HORIZONS_S: tuple[float, ...] = (1.0, 2.0)
SPEED_BANDS_MPS: tuple[tuple[float, float], ...] = ((0.0, 0.75), (0.75, 1.25), (1.25, 1.75), (1.75, 10.0))
"""Bands of the logged speed at the segment's start (the real runs command 1 and 2 m/s)."""
REPLAY_STEP_S = 1.0 / 15.0
"""How long each logged row is replayed: DeepRacer's camera rate (the logged tstamps jitter; see the docstring)."""
SEGMENT_STRIDE_ROWS = 8
"""A segment starts every 8 rows (~0.5 s) of an episode; segments overlap."""


@dataclass(frozen=True)
class Segment:
    """Logged rows `start-2 .. start+n` of one episode, as arrays; index 2 is the start pose."""

    source: str
    episode: int
    times_s: np.ndarray
    """Logged time each pose holds at: tstamp of the row before."""
    model_xy: np.ndarray
    yaw_rad: np.ndarray
    steer_deg: np.ndarray
    throttle_mps: np.ndarray

    @property
    def origin_xy(self) -> np.ndarray:
        heading = np.stack([np.cos(self.yaw_rad), np.sin(self.yaw_rad)], axis=1)
        return self.model_xy - Car.FRONT_OF_CAR_M * heading

    @property
    def replay_times_s(self) -> np.ndarray:
        """The poses' times as the replay steps them: REPLAY_STEP_S apart from the first logged time."""
        return self.times_s[0] + REPLAY_STEP_S * np.arange(len(self.times_s))

    def start_state(self) -> tuple[float, float, float, float, float, float]:
        """(x, y, yaw, vx, vy, yaw rate) of the car origin at the start pose (central differences)."""
        origin, yaw, t = self.origin_xy, np.unwrap(self.yaw_rad), self.replay_times_s
        dt = t[3] - t[1]
        vx, vy = (origin[3] - origin[1]) / dt
        return (
            float(origin[2, 0]),
            float(origin[2, 1]),
            float(yaw[2]),
            float(vx),
            float(vy),
            float((yaw[3] - yaw[1]) / dt),
        )

    @property
    def start_speed_mps(self) -> float:
        _, _, _, vx, vy, _ = self.start_state()
        return math.hypot(vx, vy)


def load_segments(
    paths: Iterable[Path], horizon_s: float = max(HORIZONS_S), stride_rows: int = SEGMENT_STRIDE_ROWS
) -> list[Segment]:
    """Segments of `horizon_s` (plus one row) of uninterrupted `in_progress` driving from real simtrace files, one
    starting every `stride_rows` rows of an episode."""
    segments: list[Segment] = []
    for path in paths:
        rows = read_simtrace(Path(path).read_bytes(), source=str(path))
        for episode, group in rows.groupby("episode", sort=False):
            status = group.episode_status.to_numpy()
            tstamp = group.tstamp.to_numpy(dtype=np.float64)
            columns = {name: group[name].to_numpy(dtype=np.float64) for name in ("X", "Y", "yaw", "steer", "throttle")}
            n = len(group)
            for start in range(3, n, stride_rows):
                # Poses start-2 .. end need tstamp of the row before each: rows start-3 .. end-1.
                end = start + 1
                while end < n and tstamp[end - 1] - tstamp[start - 1] < horizon_s + 0.03:
                    end += 1
                if end >= n or tstamp[end - 1] - tstamp[start - 1] < horizon_s:
                    break
                window = slice(start - 2, end + 1)
                if not all(s == "in_progress" for s in status[start - 2 : end + 1]):
                    continue
                segments.append(
                    Segment(
                        source=Path(path).name,
                        episode=int(episode),
                        times_s=tstamp[start - 3 : end],
                        model_xy=np.stack([columns["X"][window], columns["Y"][window]], axis=1),
                        yaw_rad=np.radians(columns["yaw"][window]),
                        steer_deg=columns["steer"][window],
                        throttle_mps=columns["throttle"][window],
                    )
                )
    return segments


class CarReplay:
    """Racer's car (the base world: DeepRacer's tyre μ 0.5) driven by logged commands, outside the env's rules."""

    def __init__(self, route: Path, dynamics: CarDynamics = SIMTRACE_FIT_DYNAMICS) -> None:
        """`dynamics`: the car to replay; by default the simtrace fit (the constants fitted to the ROS 1 console and
        DRfC logs), not the env's default car (the default generation's)."""
        self.env = DeepRacerEnv(EnvConfig(track=route, world="base", car_dynamics=dynamics))
        self.model, self.data, self.car = self.env.model, self.env.data, self.env.car
        self.timestep_s = float(self.model.opt.timestep)
        self._wheel_dofs = [int(self.model.joint(f"{name}_joint").dofadr[0]) for name in WHEEL_NAMES]
        self._hinge_qpos = [int(self.model.joint(name).qposadr[0]) for name in STEERING_JOINTS]

    def close(self) -> None:
        self.env.close()

    def run(self, segment: Segment) -> tuple[np.ndarray, np.ndarray]:
        """Predicted (model point xy, yaw) at each logged pose from the start pose on (index 2 onwards)."""
        model, data, car = self.model, self.data, self.car
        x, y, yaw, vx, vy, yaw_rate = segment.start_state()
        car.teleport(model, data, x, y, yaw)
        data.qvel[car.dof_adr : car.dof_adr + 2] = (vx, vy)
        data.qvel[car.dof_adr + 5] = yaw_rate
        speed = math.hypot(vx, vy)
        for dof in self._wheel_dofs:
            data.qvel[dof] = speed / WHEEL_RADIUS_M
        previous_speed, previous_steer = clip_command(segment.throttle_mps[1], segment.steer_deg[1])
        for adr in self._hinge_qpos:
            data.qpos[adr] = math.radians(previous_steer)
        car.command(data, previous_speed, previous_steer)
        mujoco.mj_forward(model, data)
        points, yaws = [], []
        substeps = max(1, round(REPLAY_STEP_S / self.timestep_s))
        for k in range(2, len(segment.times_s) - 1):
            pose = car.pose(data)
            points.append(pose.model_point)
            yaws.append(pose.yaw_rad)
            car.command(data, *clip_command(segment.throttle_mps[k], segment.steer_deg[k]))
            car.step(model, data, substeps)
        pose = car.pose(data)
        points.append(pose.model_point)
        yaws.append(pose.yaw_rad)
        return np.asarray(points), np.asarray(yaws)


@dataclass(frozen=True)
class SegmentError:
    start_speed_mps: float
    position_m: dict[float, float]
    heading_deg: dict[float, float]
    along_track_m: dict[float, float]
    """Signed, along the logged heading at the compared pose: negative = racer's car is behind the real one."""
    cross_track_m: dict[float, float]
    """Signed, to the left of the logged heading at the compared pose."""
    turn_deg: dict[float, float]
    """Heading change since the start, racer's minus the log's, signed so that negative = racer turns less."""


def segment_errors(segment: Segment, predicted_xy: np.ndarray, predicted_yaw: np.ndarray) -> SegmentError:
    """Errors at the logged poses nearest to each horizon after the start pose."""
    times = segment.times_s[2:]
    logged_yaw, racer_yaw = np.unwrap(segment.yaw_rad), np.unwrap(predicted_yaw)
    position, heading, along, cross, turn = {}, {}, {}, {}, {}
    for horizon in HORIZONS_S:
        k = int(np.argmin(np.abs(times - times[0] - horizon)))
        dx, dy = predicted_xy[k] - segment.model_xy[2 + k]
        position[horizon] = float(math.hypot(dx, dy))
        difference = (predicted_yaw[k] - segment.yaw_rad[2 + k] + math.pi) % (2 * math.pi) - math.pi
        heading[horizon] = abs(math.degrees(difference))
        cos_h, sin_h = math.cos(segment.yaw_rad[2 + k]), math.sin(segment.yaw_rad[2 + k])
        along[horizon] = float(dx * cos_h + dy * sin_h)
        cross[horizon] = float(-dx * sin_h + dy * cos_h)
        logged_turn = logged_yaw[2 + k] - logged_yaw[2]
        racer_turn = racer_yaw[k] - racer_yaw[0]
        turn[horizon] = math.degrees((racer_turn - logged_turn) * (1.0 if logged_turn >= 0 else -1.0))
    return SegmentError(segment.start_speed_mps, position, heading, along, cross, turn)


def band_label(low: float, high: float) -> str:
    return f"{low:g}-{high:g} m/s" if high < 10 else f">= {low:g} m/s"


def summarise(errors: Sequence[SegmentError]) -> dict[str, dict]:
    """Median and 90th percentile per speed band and horizon: position error in m, heading error in degrees; the
    median signed along-track error, absolute cross-track error and turn error (racer minus log) split them up."""
    table: dict[str, dict] = {}
    for low, high in SPEED_BANDS_MPS:
        members = [e for e in errors if low <= e.start_speed_mps < high]
        entry: dict[str, float | int] = {"segments": len(members)}
        for horizon in HORIZONS_S:
            if not members:
                continue
            position = np.array([e.position_m[horizon] for e in members])
            heading = np.array([e.heading_deg[horizon] for e in members])
            entry[f"position_m_{horizon:g}s_median"] = round(float(np.median(position)), 4)
            entry[f"position_m_{horizon:g}s_p90"] = round(float(np.percentile(position, 90)), 4)
            entry[f"heading_deg_{horizon:g}s_median"] = round(float(np.median(heading)), 2)
            entry[f"heading_deg_{horizon:g}s_p90"] = round(float(np.percentile(heading, 90)), 2)
            # Where the error comes from: a speed bias shows in along-track, a steering one in cross-track and turn.
            along = [e.along_track_m[horizon] for e in members]
            entry[f"along_track_m_{horizon:g}s_median"] = round(float(np.median(along)), 4)
            entry[f"cross_track_m_{horizon:g}s_median_abs"] = round(
                float(np.median([abs(e.cross_track_m[horizon]) for e in members])), 4
            )
            entry[f"turn_deg_{horizon:g}s_median"] = round(float(np.median([e.turn_deg[horizon] for e in members])), 2)
        table[band_label(low, high)] = entry
    return table


def goal_met(bands: dict[str, dict]) -> bool:
    """Whether every populated band's median position error after 1 s is at most 5 cm."""
    return all(entry.get("position_m_1s_median", math.inf) <= 0.05 for entry in bands.values() if entry["segments"])


def error_table(segments: Sequence[Segment], files: int, errors: Sequence[SegmentError]) -> dict:
    """The bench's figures for the errors of `segments` from `files` simtrace files: per band (`summarise`) and
    whether every band meets the 5 cm goal."""
    bands = summarise(errors)
    return {
        "segments": len(segments),
        "files": files,
        "bands": bands,
        "goal_median_position_1s_le_0_05_m": goal_met(bands),
    }


def replay_errors(replay: CarReplay, segments: Sequence[Segment], progress: bool = False) -> list[SegmentError]:
    """Each segment replayed with the replay's car as it stands, in order."""
    errors = []
    for index, segment in enumerate(segments):
        errors.append(segment_errors(segment, *replay.run(segment)))
        if progress and (index + 1) % 200 == 0:
            print(f"replayed {index + 1}/{len(segments)} segments", file=sys.stderr, flush=True)
    return errors


def load_replayable(simtraces: Sequence[Path]) -> list[Segment]:
    """The segments of the files; a usage error naming them when none is long enough."""
    segments = load_segments(simtraces)
    if not segments:
        raise click.ClickException(
            f"no replayable segments ({max(HORIZONS_S):g} s of in_progress rows) in "
            f"{', '.join(str(p) for p in simtraces)}"
        )
    return segments


TRACK_LENGTH_TOLERANCE_M = 0.01
"""A file counts as driven on the route when its logged `track_len` is the route's length within 1 cm."""


def files_on_route(paths: Sequence[Path], route: Path) -> tuple[list[Path], list[Path]]:
    """(the files driven on `route`, the others): a simtrace's `track_len` is the length of the track it was logged
    on, and replaying a log on another track's floor compares nothing."""
    length_m = Track.load(route).length_m
    on_route, elsewhere = [], []
    for path in paths:
        logged = read_simtrace(Path(path).read_bytes(), source=str(path)).track_len
        matches = len(logged) > 0 and abs(float(logged.iloc[0]) - length_m) <= TRACK_LENGTH_TOLERANCE_M
        (on_route if matches else elsewhere).append(Path(path))
    return on_route, elsewhere


def replay_files(simtraces: Path, route: Path) -> list[Path]:
    """The simtrace CSV, or a folder's CSVs in name order, driven on `route`; files of other tracks are left out and
    named on stderr, and none left is a usage error."""
    paths = sorted(simtraces.glob("*.csv")) if simtraces.is_dir() else [simtraces]
    on_route, elsewhere = files_on_route(paths, route)
    if elsewhere:
        names = ", ".join(path.name for path in elsewhere)
        print(f"fidelity: left out (driven on another track than {route.name}): {names}", file=sys.stderr, flush=True)
    if not on_route:
        raise click.ClickException(f"no simtrace in {simtraces} was driven on {route} (their track_len differs)")
    return on_route


def run_fidelity(simtraces: Sequence[Path], route: Path, progress: bool = False, car: str = "simtrace-fit") -> dict:
    """The replay's error table for the car preset `car` (`car.dynamics.CAR_DYNAMICS`)."""
    segments = load_replayable(simtraces)
    replay = CarReplay(route, CAR_DYNAMICS[car])
    try:
        errors = replay_errors(replay, segments, progress)
    finally:
        replay.close()
    return {**error_table(segments, len(simtraces), errors), "car": car}


@click.command(name="fidelity")
@click.option(
    "--simtraces",
    type=click.Path(exists=True, path_type=Path),
    default=None,
    help="A real simtrace CSV or a folder of them (DeepRacer runs on re:Invent 2018). Default: simtrace/ of --data.",
)
@click.option(
    "--route",
    type=click.Path(exists=True, dir_okay=False, path_type=Path),
    default=None,
    help="The route the simtraces were driven on (the floor the car replays on); files logged on another track "
    "are left out. Default: re:Invent 2018 from --data.",
)
@click.option(
    "--car",
    type=click.Choice(sorted(CAR_DYNAMICS)),
    default=None,
    help="The car profile to replay. Default: the --generation's car, else simtrace-fit (the car fitted on the "
    "default logs, DeepRacer's ROS 1 console and DRfC runs; docs/car-and-camera.md).",
)
@click.option(
    "--generation",
    type=click.Choice(GENERATION_NAMES),
    default=None,
    help="Replay this generation's car (simapp6: fitted on DeepRacer on AWS's 2026 logs); --car replaces it.",
)
@data_option
def fidelity_bench_command(
    simtraces: Path | None, route: Path | None, car: str | None, generation: str | None, data_dir: Path | None
) -> None:
    """Open-loop replay of real simtraces: median and p90 position/heading error after 1 s and 2 s per speed band."""
    car = car or (GENERATIONS[generation].car_profile if generation else "simtrace-fit")
    if simtraces is None or route is None:
        data = data_folder(data_dir)
        simtraces = simtraces or data / "simtrace"
        route = route or data / REINVENT_2018_ROUTE
    click.echo(json.dumps(run_fidelity(replay_files(simtraces, route), route, progress=True, car=car)))
