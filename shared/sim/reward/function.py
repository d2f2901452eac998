"""Loading and calling users' DeepRacer reward functions, with DeepRacer's output rules
(deepracer-simapp v5.3.3 `bundle/markov/agent_ctrl/rollout_agent_ctrl.py`).

The file is executed once as its own module, so module-level state (counters, objects) persists across calls,
as in DeepRacer's long-lived rollout process. A failing function is reported with its traceback (file and line);
a result that is not a finite number within ±1e5 is an error naming the file.
"""

from __future__ import annotations

import importlib.util
import math
import traceback
from collections.abc import Callable, Mapping
from pathlib import Path
from types import ModuleType

from racer.shared.sim.reward.params import copy_params

REWARD_LIMIT = 1e5
"""DeepRacer rejects rewards outside [-1e5, 1e5]."""

FUNCTION_NAME = "reward_function"


class RewardFunctionError(ValueError):
    """The reward function could not be loaded, raised, or returned an unusable value."""


PARAMS_SHOWN = ("x", "y", "heading", "speed", "steering_angle", "progress", "steps", "distance_from_center",
                "is_left_of_center", "all_wheels_on_track", "is_offtrack", "is_reversed", "closest_waypoints",
                "closest_objects", "objects_location")  # fmt: skip
"""The params an error message shows, enough to recreate the pose (`racer reward test` shows every one)."""


def describe_params(params: Mapping) -> str:
    """A one-line summary of the params a reward function was called with, numbers rounded."""

    def short(value: object) -> str:
        if isinstance(value, float):
            return f"{value:.4g}"
        if isinstance(value, (list, tuple)):
            inner = ", ".join(short(item) for item in list(value)[:4])
            return f"[{inner}{', ...' if len(value) > 4 else ''}]"
        return repr(value)

    return ", ".join(f"{name}={short(params[name])}" for name in PARAMS_SHOWN if name in params)


def _user_traceback(exc: BaseException, path: Path) -> str:
    """The traceback without the frames of this module, so the user's file and line come first."""
    frames = [f for f in traceback.extract_tb(exc.__traceback__) if f.filename != __file__]
    lines = traceback.format_list(frames) + traceback.format_exception_only(type(exc), exc)
    return "".join(lines).rstrip() or f"{type(exc).__name__}: {exc} (in {path})"


class RewardFunction:
    """A user's `reward_function(params)` loaded from a file; call it with a params dict to get a float."""

    def __init__(self, path: str | Path, function: Callable[[dict], object], module: ModuleType | None = None) -> None:
        self.path = Path(path)
        self._function = function
        self.module = module

    def __call__(self, params: Mapping) -> float:
        try:
            value = self._function(copy_params(dict(params)))
        # A user function may raise anything; it is re-raised with its traceback, never swallowed.
        except Exception as exc:
            raise RewardFunctionError(
                f"reward function {self.path} raised {type(exc).__name__}:\n{_user_traceback(exc, self.path)}\n"
                f"with params {describe_params(params)}"
            ) from exc
        try:
            return check_reward_value(value, self.path)
        except RewardFunctionError as error:
            raise RewardFunctionError(f"{error}\nwith params {describe_params(params)}") from None

    def __repr__(self) -> str:
        return f"RewardFunction({str(self.path)!r})"


def check_reward_value(value: object, path: str | Path) -> float:
    """DeepRacer's `float(reward)` plus its finiteness and ±1e5 range checks, with a clear message.

    Whatever `float()` takes is a reward, as in the SimApp: a numeric string such as '1.5' too."""
    try:
        reward = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError) as exc:
        raise RewardFunctionError(
            f"reward function {path} returned {value!r} ({type(value).__name__}); it must return a number"
        ) from exc
    if not math.isfinite(reward):
        raise RewardFunctionError(f"reward function {path} returned {reward}; the reward must be a finite number")
    if abs(reward) > REWARD_LIMIT:
        raise RewardFunctionError(
            f"reward function {path} returned {reward}; the reward must be within [-{REWARD_LIMIT:g}, {REWARD_LIMIT:g}]"
        )
    return reward


def load_reward_function(path: str | Path) -> RewardFunction:
    """Execute a reward file once and return its `reward_function` as a checked callable."""
    path = Path(path)
    if not path.is_file():
        raise RewardFunctionError(f"reward function file not found: {path}")
    module_name = f"racer_user_reward_{abs(hash(str(path.resolve())))}"
    spec = importlib.util.spec_from_file_location(module_name, path)
    if spec is None or spec.loader is None:
        raise RewardFunctionError(f"{path}: cannot be loaded as a Python file")
    module = importlib.util.module_from_spec(spec)
    try:
        spec.loader.exec_module(module)
    except SyntaxError as exc:
        raise RewardFunctionError(
            f"{path}:{exc.lineno}: syntax error: {exc.msg}\n{_user_traceback(exc, path)}"
        ) from exc
    # Importing user code may raise anything; it is reported with its traceback.
    except Exception as exc:
        raise RewardFunctionError(
            f"{path}: loading the reward file raised {type(exc).__name__}:\n{_user_traceback(exc, path)}"
        ) from exc
    function = getattr(module, FUNCTION_NAME, None)
    if function is None:
        raise RewardFunctionError(f"{path}: defines no function named {FUNCTION_NAME!r}")
    if not callable(function):
        raise RewardFunctionError(f"{path}: {FUNCTION_NAME!r} is not callable")
    return RewardFunction(path, function, module)


def default_evaluation_reward(params: Mapping) -> float:
    """DeepRacer's evaluation-time reward: centre-line markers at 0.1/0.25/0.5 of the width → 1/0.5/0.1/1e-3."""
    width = params["track_width"]
    distance = params["distance_from_center"]
    if distance <= 0.1 * width:
        return 1.0
    if distance <= 0.25 * width:
        return 0.5
    if distance <= 0.5 * width:
        return 0.1
    return 1e-3
