"""`racer reward test`: call a user's reward function on the params DeepRacer can produce, all over a track.

The params come from `make_reward_params` (the same builder the env uses) at poses spread along the whole track:
across its width and beyond it (off track), with headings around the track direction and reversed, with each action
of the model's action space, driven the other way (`is_reversed`), and with the obstacles or bot cars of the race
type (close to them too). Reported as errors: every exception (file, line, the params that raised it), returns that
are not numbers (a numeric string is fine: DeepRacer calls `float()`), not finite or outside [-1e5, 1e5], and calls
slower than 1 ms on average. Reported as warnings: what DeepRacer on AWS's reward validator would reject (imports
other than math, random, numpy, scipy, shapely; calls of open, eval, exec, compile, input), found with `ast`.
"""

from __future__ import annotations

import ast
import math
import signal
import sys
import threading
import time
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from racer.reward.probes import Pose, model_actions, params_at, poses, probe_objects
from racer.shared.deepracer.model_metadata import ModelMetadata
from racer.shared.sim.objects.challenge import RACE_TYPES
from racer.shared.sim.reward.function import REWARD_LIMIT, RewardFunctionError, load_reward_function
from racer.shared.sim.reward.params import copy_params
from racer.shared.sim.tracks.track import Track

ALLOWED_MODULES = ("math", "random", "numpy", "scipy", "shapely")
"""What DeepRacer on AWS's validator lets a reward file import."""
FORBIDDEN_CALLS = ("open", "eval", "exec", "compile", "input")
SLOW_CALL_S = 1e-3
"""A reward slower than this per call on average is an error: DeepRacer calls it 15 times a second per car, and
slow rewards make every rollout slower."""


class _OutOfTime(BaseException):
    """Raised into a reward call that overruns the time budget (BaseException: a user's `except Exception` does not
    swallow it)."""


@dataclass(frozen=True)
class Finding:
    """One problem: what, where in the user's file, and the params of the first call that showed it."""

    severity: str
    """`error` or `warning`."""
    message: str
    file: str | None = None
    line: int | None = None
    params: dict | None = None
    count: int = 1

    def format(self) -> str:
        where = f"{self.file}:{self.line}: " if self.file and self.line else (f"{self.file}: " if self.file else "")
        times = f" ({self.count} calls)" if self.count > 1 else ""
        text = f"{self.severity}: {where}{self.message}{times}"
        if self.params is not None:
            text += "\n    params: " + _params_text(self.params)
        return text


@dataclass
class RewardCheckReport:
    path: Path
    track: str
    race_type: str
    calls: int = 0
    mean_call_s: float = 0.0
    findings: list[Finding] = field(default_factory=list)
    complete: bool = True

    @property
    def errors(self) -> list[Finding]:
        return [f for f in self.findings if f.severity == "error"]

    @property
    def warnings(self) -> list[Finding]:
        return [f for f in self.findings if f.severity == "warning"]

    @property
    def ok(self) -> bool:
        return not self.errors

    def format(self) -> str:
        head = (
            f"{self.path}: {self.calls} calls on {self.track} ({self.race_type}), "
            f"{self.mean_call_s * 1e3:.3f} ms per call on average: "
            f"{len(self.errors)} error(s), {len(self.warnings)} warning(s)"
        )
        return "\n".join([head, *(f.format() for f in self.findings)])


def _params_text(params: dict) -> str:
    shown = {k: (f"<{len(v)} points>" if k == "waypoints" else v) for k, v in params.items()}
    return ", ".join(f"{k}={v!r}" for k, v in shown.items())


def static_findings(path: Path, source: str) -> list[Finding]:
    """DeepRacer on AWS's validator rules, from the syntax tree: imports outside ALLOWED_MODULES, forbidden calls."""
    try:
        tree = ast.parse(source, filename=str(path))
    except SyntaxError:
        return []  # loading reports it as an error, with its line
    found: list[Finding] = []
    for node in ast.walk(tree):
        modules: list[str] = []
        if isinstance(node, ast.Import):
            modules = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            modules = [node.module or "." * node.level] if node.level == 0 else ["." * node.level + (node.module or "")]
        for module in modules:
            if module.split(".")[0] not in ALLOWED_MODULES:
                found.append(
                    Finding(
                        "warning",
                        f"imports {module}: DeepRacer on AWS accepts only imports of {', '.join(ALLOWED_MODULES)}",
                        str(path),
                        node.lineno,
                    )
                )
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in FORBIDDEN_CALLS:
            found.append(
                Finding(
                    "warning",
                    f"calls {node.func.id}(): DeepRacer on AWS rejects reward functions that use "
                    f"{', '.join(FORBIDDEN_CALLS)}",
                    str(path),
                    node.lineno,
                )
            )
    return sorted(found, key=lambda f: f.line or 0)


def _user_frame(exc: BaseException, path: Path) -> tuple[str, int | None]:
    """The deepest frame of the user's file (or the deepest frame at all) of an exception's traceback."""
    frames = traceback.extract_tb(exc.__traceback__)
    resolved = str(path.resolve())
    mine = [f for f in frames if f.filename and Path(f.filename).resolve().as_posix() == Path(resolved).as_posix()]
    frame = (mine or frames[1:] or frames)[-1] if frames else None
    if frame is None:
        return str(path), None
    return frame.filename, frame.lineno


class _Budget:
    """Ends the calls after `seconds`: a timer signal interrupts a call that hangs (main thread only); otherwise the
    loop checks the clock between calls."""

    def __init__(self, seconds: float) -> None:
        self.deadline = time.perf_counter() + seconds
        self.seconds = seconds
        self._armed = False

    def __enter__(self) -> _Budget:
        if threading.current_thread() is threading.main_thread() and hasattr(signal, "setitimer"):
            self._previous = signal.signal(signal.SIGALRM, self._expire)
            signal.setitimer(signal.ITIMER_REAL, self.seconds)
            self._armed = True
        return self

    def _expire(self, signum, frame) -> None:
        raise _OutOfTime

    def __exit__(self, *exc: object) -> None:
        if self._armed:
            signal.setitimer(signal.ITIMER_REAL, 0)
            signal.signal(signal.SIGALRM, self._previous)

    def over(self) -> bool:
        return time.perf_counter() > self.deadline


def _value_problem(value: object) -> str | None:
    try:
        reward = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return f"returned {value!r} ({type(value).__name__}): the reward must be a number"
    if not math.isfinite(reward):
        return f"returned {reward}: the reward must be a finite number"
    if abs(reward) > REWARD_LIMIT:
        return f"returned {reward}: the reward must be within [-{REWARD_LIMIT:g}, {REWARD_LIMIT:g}]"
    return None


def check_reward_file(
    path: str | Path,
    track: Track,
    race_type: str = "TIME_TRIAL",
    metadata: ModelMetadata | None = None,
    *,
    quick: bool = False,
    time_budget_s: float = 6.0,
) -> RewardCheckReport:
    """Load the reward file and call it over the track; see the module docstring for what is reported."""
    path = Path(path)
    if race_type not in RACE_TYPES:
        raise ValueError(f"race type {race_type!r} is not one of {', '.join(RACE_TYPES)}")
    report = RewardCheckReport(path, track.name, race_type)
    try:
        source = path.read_text(encoding="utf-8-sig")
    except OSError as error:
        report.findings.append(Finding("error", f"cannot read the file: {error}", str(path)))
        return report
    report.findings.extend(static_findings(path, source))
    try:
        function = load_reward_function(path).module.reward_function  # type: ignore[union-attr]
    except RewardFunctionError as error:
        report.findings.append(Finding("error", str(error), str(path)))
        return report
    objects = probe_objects(track, race_type)
    objects_at = [track.project_normalized(o.x, o.y) for o in objects]
    errors: dict[tuple, Finding] = {}
    spent = 0.0
    with _Budget(time_budget_s) as budget:
        try:
            for pose in poses(model_actions(metadata), objects_at, quick):
                if budget.over():
                    report.complete = False
                    break
                params = params_at(track, pose, objects)
                problem, key, where = _call(function, params, path)
                report.calls += 1
                spent += problem[1]
                if problem[0] is None:
                    continue
                finding = errors.get(key)
                if finding is None:
                    line = where[1] if key[0] == "raise" else _return_line(function, params, path)
                    errors[key] = Finding("error", problem[0], where[0], line, params)
                else:
                    errors[key] = Finding("error", finding.message, finding.file, finding.line, finding.params,
                                          finding.count + 1)  # fmt: skip
        except _OutOfTime:
            report.complete = False
    report.findings.extend(errors.values())
    report.mean_call_s = spent / report.calls if report.calls else 0.0
    if not report.complete:
        report.findings.append(
            Finding(
                "error",
                f"stopped after {report.calls} calls: the checks took longer than {time_budget_s:g} s "
                f"({report.mean_call_s * 1e3:.1f} ms per call)",
                str(path),
            )
        )
    elif report.mean_call_s > SLOW_CALL_S:
        report.findings.append(
            Finding(
                "error",
                f"slow: {report.mean_call_s * 1e3:.2f} ms per call on average (limit {SLOW_CALL_S * 1e3:g} ms); "
                "DeepRacer calls it every step",
                str(path),
            )
        )
    return report


def _call(function: Callable, params: dict, path: Path) -> tuple[tuple[str | None, float], tuple, tuple]:
    """((problem or None, seconds), grouping key, (file, line)) of one call."""
    start = time.perf_counter()
    try:
        value = function(copy_params(params))
    except _OutOfTime:
        raise
    # A user's function may raise anything: each is reported with its place, never swallowed silently.
    except Exception as exc:  # noqa: BLE001
        elapsed = time.perf_counter() - start
        file, line = _user_frame(exc, path)
        return (f"raised {type(exc).__name__}: {exc}", elapsed), ("raise", type(exc).__name__, file, line), (file, line)
    elapsed = time.perf_counter() - start
    problem = _value_problem(value)
    if problem is None:
        return (None, elapsed), (), ()
    kind = problem.split(":")[1] if ":" in problem else problem
    return (problem, elapsed), ("value", kind), (str(path), None)


def _return_line(function: Callable, params: dict, path: Path) -> int | None:
    """The line of the user's `return` that produced a bad value: the call is made once more under a profiler that
    notes the deepest return in the user's file whose value is the one the function returned."""
    resolved = path.resolve()
    returns: list[tuple[int, object]] = []

    same: dict[str, bool] = {}

    def profile(frame, event, arg) -> None:
        name = frame.f_code.co_filename
        if name not in same:
            same[name] = Path(name).resolve() == resolved
        if event == "return" and same[name]:
            returns.append((frame.f_lineno, arg))

    sys.setprofile(profile)
    try:
        value = function(copy_params(params))
    except Exception:  # noqa: BLE001 (the first call already returned; a second one that raises names no line)
        return None
    finally:
        sys.setprofile(None)
    for line, returned in returns:
        if returned is value or (returned == value if isinstance(value, str) else False):
            return line
    return returns[-1][0] if returns else None


def reward_map(
    path: str | Path,
    track: Track,
    race_type: str,
    metadata: ModelMetadata | None,
    out: str | Path,
    time_budget_s: float = 3.0,
) -> Path:
    """Draw the reward over the track for the slowest and fastest speed, heading along the track and 30° off it."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    function = load_reward_function(path).module.reward_function  # type: ignore[union-attr]
    actions = model_actions(metadata)
    speeds = sorted({a[1] for a in actions})
    cases = [(speeds[0], 0.0), (speeds[-1], 0.0), (speeds[0], 30.0), (speeds[-1], 30.0)]
    objects = probe_objects(track, race_type)
    fig, axes = plt.subplots(2, 2, figsize=(12, 9), dpi=90)
    deadline = time.perf_counter() + time_budget_s
    stations = max(40, min(120, int(track.length_m * 3)))
    for ax, (speed, heading) in zip(axes.flat, cases, strict=True):
        xs, ys, values = [], [], []
        for s in range(stations):
            for lateral in (-0.45, -0.3, -0.15, 0.0, 0.15, 0.3, 0.45):
                if time.perf_counter() > deadline:
                    break
                params = params_at(track, Pose(s / stations, lateral, heading, (0.0, speed)), objects)
                try:
                    value = float(function(copy_params(params)))
                except Exception:  # noqa: BLE001 (the check reports it; the map leaves the point out)
                    continue
                if math.isfinite(value):
                    xs.append(params["x"])
                    ys.append(params["y"])
                    values.append(value)
        ax.plot(track.inner_border[:, 0], track.inner_border[:, 1], color="k", lw=0.8)
        ax.plot(track.outer_border[:, 0], track.outer_border[:, 1], color="k", lw=0.8)
        for o in objects:
            ax.plot([o.x], [o.y], "s", color="red", markersize=6)
        points = ax.scatter(xs, ys, c=values, s=8, cmap="viridis")
        fig.colorbar(points, ax=ax, shrink=0.8)
        ax.set_aspect("equal")
        ax.set_title(f"speed {speed:g} m/s, heading {heading:+g}° to the track", fontsize=9)
    fig.suptitle(f"{Path(path).name} on {track.name} ({race_type})")
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, bbox_inches="tight")
    plt.close(fig)
    return out
