"""`DeepRacerEnv`: the MuJoCo DeepRacer simulator as a Gymnasium environment, with the SimApp's episode semantics."""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np

from racer.shared.deepracer.episode_status import EpisodeStatus
from racer.shared.sim.car.dynamics import CarDynamics
from racer.shared.sim.car.episode_car import EpisodeCar
from racer.shared.sim.car.vehicle import (
    CAMERA_PITCH_DOWN_RAD,
    Car,
    camera_mount_m,
    clip_command,
    command_wheel_radius_m,
)
from racer.shared.sim.config import STEPS_PER_SECOND, EnvConfig
from racer.shared.sim.episode.judged_pose import PoseJudge, judged_reward_params
from racer.shared.sim.episode.phase import PhaseMachine, StepVerdict
from racer.shared.sim.episode.start import StartRotation, episode_max_steps, read_reset_options, start_offset
from racer.shared.sim.episode.step_info import step_info
from racer.shared.sim.objects.bodies import ObjectBodies
from racer.shared.sim.objects.poses import ObjectPose
from racer.shared.sim.objects.track_objects import TrackObjects, object_slots
from racer.shared.sim.reward.function import RewardFunction, default_evaluation_reward, load_reward_function
from racer.shared.sim.scene._mujoco import mujoco
from racer.shared.sim.scene.domain_randomization import SceneRandomizer
from racer.shared.sim.scene.mjcf import SceneSpec, build_model
from racer.shared.sim.scene.simapp_world import load_simapp_world
from racer.shared.sim.scene.worlds import get_world
from racer.shared.sim.sensors.observation import Observer, scene_cameras
from racer.shared.sim.sensors.spaces import ChosenAction, action_space, decode_action, observation_space
from racer.shared.sim.tracks.track import Track

_SCENE_RNG_STREAM = 22
"""Seeds the scene randomisation apart from the LIDAR noise (which uses `np_random`)."""


class DeepRacerEnv(gym.Env):
    """AWS DeepRacer's time-trial simulation in MuJoCo.

    ## Description
    A 1/18 car (DeepRacer geometry, deepracer-simapp v5.3.3 `bundle/urdf/deepracer/`) drives on a route
    (`tracks/*.npy` or a DeepRacer route file) in one of four worlds (base, carpet, concrete, wood). Episode rules, reward params and simtrace rows follow
    the SimApp exactly (deepracer-simapp v5.3.3 `bundle/markov/agent_ctrl/`, `bundle/markov/metrics/`). 15 steps per
    simulated second.

    ## Action space
    From `model_metadata`: `Discrete(n)` over the discrete action list, or `Box(-1, 1, (2,), float32)` =
    [steering, speed] for a continuous space (clipped to [-1, 1], then scaled linearly onto the metadata ranges).
    The car receives the command clipped to 0.1–4 m/s and ±30°; the reward params see the unclipped values.

    ## Observation space
    `Dict` keyed by the metadata's `sensor` names:
    camera (`FRONT_FACING_CAMERA`, `LEFT_CAMERA`, `observation`) `Box(0, 255, (120, 160, 1), uint8)`,
    `STEREO_CAMERAS` `(120, 160, 2)` (left, right); `LIDAR` `(64,)` float32 in [0.15, 1];
    `SECTOR_LIDAR` `(8,)` float32 bits; `DISCRETIZED_SECTOR_LIDAR` `(num_sectors·num_values_per_sector,)` bits.

    ## Step ordering (deepracer-simapp v5.3.3 `bundle/markov/environments/deepracer_racetrack_env.py`)
    `step(a_t)` reads the pose first (where observation o_t was taken) and judges the rules on it, then drives the
    car with a_t for 1/15 s and returns o_{t+1}. Params, reward and simtrace row describe that first pose; they are
    computed while o_{t+1} renders. The row's `tstamp` is the clock after the physics (as the SimApp's), so the
    prepare row is 1/15 s after the episode start and a lap ends at its last row's `tstamp`. The first step of every
    episode is the `prepare` step: the car gets a zero command whatever the action, reward 0. The episode's phases
    (prepare, run, pause), its rules and resets are `episode_phase.PhaseMachine`'s.

    ## Rewards
    The user's `reward_function(params)` (every params key present) on RUN steps, including the terminal one;
    0 on `prepare` and `pause` steps. Without a reward file, DeepRacer's evaluation reward.

    ## Episode end
    terminated on `lap_complete` (progress ≥ 100) and on `off_track` (no wheel centre on the road), `immobilized`
    (≤ 0.3 mm of movement for 15 steps), `reversed` (progress decreasing for `number_of_reverse_counts` steps) or
    `crashed` once the `number_of_resets` pause-and-resets are used up; truncated after `max_steps` (100000) steps,
    or after `reset(options={"max_steps": n})`'s n for that episode (racer's evaluation step cap).
    With resets left, the car is put back and held for the penalty: `pause` rows, at least one even for a 0 s
    penalty, `pause_duration` counting down to what is left (negative on the last row when the penalty is not a
    whole number of steps). The SimApp's spot (`reset_position="deepracer"`): the previous progress as a share of the
    lap from the route's origin, on the lane whose spot is nearer the previous pose; the summit rule's
    (`"where_it_left"`): the centre line half a step behind the last point with four wheels on the road.

    ## Start position
    Training episodes start at `start_position_offset` and advance by `round_robin_advance_dist` of a lap after
    each finished training episode (`change_start_position`); `alternate_driving_direction` flips the direction
    after each. `reset(options={"evaluation": True})` plays an evaluation episode, which changes neither; it starts
    where the next training episode would, or at `options["start_ndist"]` (normalised distance along the route).
    Like the SimApp, a training start with an object within 1 m moves to the lane away from it and an evaluation
    start stays on the centre line, unless `options["clear_start"]` asks for the training rule (racer's evaluation
    starts spread over the lap, which may fall on a box where the SimApp's start line never does).

    ## Reproducibility
    `reset(seed=s)` seeds the LIDAR noise, the scene and dynamics randomisation and restarts the simulation clock;
    physics and rendering are deterministic, so two envs given the same seed and actions produce the same
    observations and rewards.
    The simtrace `wall_clock` comes from the `wall_clock` callable (default `time.time`).

    ## Info
    Every step: `simtrace` (dict of the 19 simtrace columns, in order), `params` (the reward params of the step),
    `episode_status`, `progress`, `evaluation`; `lap_time_s` (simulated) on a completed lap.
    `reset()` info: `episode`, `start_ndist`, `is_reversed`, `evaluation`, `start_time_s` (the sim clock at the
    reset: the metrics' `start_time`).
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": STEPS_PER_SECOND}

    def __init__(
        self,
        config: EnvConfig | None = None,
        render_mode: str | None = None,
        wall_clock: Callable[[], float] = time.time,
        track_objects: TrackObjects | None = None,
    ) -> None:
        self.config = config or EnvConfig()
        self._wall_clock = wall_clock
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode must be None or 'rgb_array', got {render_mode!r}")
        self.render_mode = render_mode
        cfg = self.config
        self._metadata = cfg.model_metadata
        self._base_track = Track.load(cfg.track, cfg.tracks_dir)
        self._tracks = {False: self._base_track, True: self._base_track.reversed()}
        self._reward: RewardFunction | None = (
            load_reward_function(cfg.reward_function_path) if cfg.reward_function_path is not None else None
        )

        # `track_objects` replaces what config.challenge describes (a multi-car race's other cars: peer_cars.PeerCars).
        slots = track_objects.slots if track_objects is not None else object_slots(cfg.challenge)
        cameras, rendered_cameras = scene_cameras(self._metadata.camera_sensor, render_mode == "rgb_array")
        self._substeps = cfg.physics_substeps
        self._model = build_model(
            SceneSpec(
                self._base_track,
                get_world(cfg.world),
                1.0 / (STEPS_PER_SECOND * self._substeps),
                cameras,
                cfg.look.camera_pos_m or camera_mount_m(self._metadata.version),
                load_simapp_world(cfg.simapp_dir, cfg.world) if cfg.simapp_dir is not None else None,
                object_slots=slots,
                car_dynamics=cfg.car_dynamics,
                look=cfg.look,
                camera_pitch_down_rad=(
                    CAMERA_PITCH_DOWN_RAD if cfg.look.camera_pitch_down_rad is None else cfg.look.camera_pitch_down_rad
                ),
            )
        )
        self._data = mujoco.MjData(self._model)
        self._car = Car(self._model, command_wheel_radius_m(self._metadata.version), cfg.car_dynamics.tyres)
        self._randomizer = SceneRandomizer(self._model, cfg.domain_randomization, cfg.car_randomization)
        self._observer = Observer(
            self._model,
            self._car.body_id,
            cfg,
            self._metadata,
            self._randomizer,
            rendered_cameras,
            keep_front_rgb=render_mode == "rgb_array",
        )
        self._camera = self._observer.camera  # the env's renderer, for tools that render at the env's poses
        self._scene_rng = np.random.default_rng()
        self._episode_car = EpisodeCar(self._car, self._model, cfg.car_dynamics, cfg.dynamics_randomization)
        self._judge = PoseJudge(self._car, self._data)
        # Obstacles and bot cars; None in a time trial, so nothing of theirs runs per step.
        self._track_objects = track_objects or (TrackObjects(cfg.challenge) if cfg.challenge.has_objects else None)
        self._objects_start_time_s = 0.0
        self._object_bodies = ObjectBodies(self._model, slots) if self._track_objects is not None else None

        self.action_space = action_space(self._metadata)
        self.observation_space = observation_space(self._metadata, cfg.image_height_px, cfg.image_width_px)

        # Round-robin state carried across episodes (per env = per rollout worker, as in the SimApp).
        self._starts = StartRotation(cfg)
        self._episode_open = False
        self._phases = PhaseMachine(
            cfg, self._track_objects, self._tracks[self._starts.reverse_dir], self._starts.start_ndist
        )
        self._init_episode_state(False, self._starts.start_ndist)

    # ----- public properties ---------------------------------------------------------------------------------

    @property
    def track(self) -> Track:
        """The route in the current episode's driving direction."""
        return self._track

    @property
    def base_track(self) -> Track:
        return self._base_track

    @property
    def model(self) -> mujoco.MjModel:
        return self._model

    @property
    def data(self) -> mujoco.MjData:
        return self._data

    @property
    def car(self) -> Car:
        return self._car

    @property
    def car_dynamics(self) -> CarDynamics:
        """The car of the current episode: `config.car_dynamics`, or this episode's draw when
        `config.dynamics_randomization` is on."""
        return self._episode_car.dynamics

    @property
    def command_delay_steps(self) -> int:
        """1 when this episode drives each step with the previous step's command (dynamics randomisation), else 0."""
        return self._episode_car.command_delay_steps

    @property
    def start_ndist(self) -> float:
        """Normalised start position of the next (or current, before its first step) training episode."""
        return self._starts.start_ndist

    @property
    def object_poses(self) -> list[ObjectPose]:
        """The obstacles and bot cars where they stand now (empty in a time trial)."""
        return self._track_objects.objects if self._track_objects is not None else []

    @property
    def sim_time_s(self) -> float:
        return float(self._data.time)

    # ----- episode lifecycle ---------------------------------------------------------------------------------

    def _init_episode_state(self, evaluation: bool, start_ndist: float) -> None:
        self._evaluation = evaluation
        self._track = self._tracks[self._starts.reverse_dir]
        self._phases.start(self._track, start_ndist)
        self._steps = 0.0
        self._episode_index = self._starts.episode_index(evaluation)
        self._episode_start_time_s = float(self._data.time)
        self._last_status = EpisodeStatus.PREPARE

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        super().reset(seed=seed)
        if seed is not None:
            # A seeded reset restarts the simulation clock too, so seeded runs are reproducible row for row.
            self._data.time = 0.0
            self._scene_rng = np.random.default_rng((seed, _SCENE_RNG_STREAM))
            self._episode_car.seed(seed)
        evaluation, start_ndist = read_reset_options(options, self._starts.start_ndist)
        self._max_steps = episode_max_steps(options, self.config.max_steps)
        self._init_episode_state(evaluation, start_ndist)
        if self._randomizer.enabled:
            self._randomizer.randomize(self._model, self._scene_rng)
        self._episode_car.start(evaluation)
        x, y, yaw = self._track.pose_at(start_ndist, "center")
        if self._track_objects is not None:
            self._objects_start_time_s = float(self._data.time)
            self._track_objects.restart(self._track, self._scene_rng)
            if not evaluation or (options or {}).get("clear_start"):  # the SimApp moves only training starts
                x, y, yaw = self._track_objects.start_pose(self._track, start_ndist) or (x, y, yaw)
            self._place_objects()
        left_m, turn_rad = start_offset(options)
        x, y, yaw = x - left_m * math.sin(yaw), y + left_m * math.cos(yaw), yaw + turn_rad
        self._car.teleport(self._model, self._data, x, y, yaw)
        if self._observer.lidar is not None:
            self._observer.lidar.reset()
        self._episode_open = True
        observation = self._observe()
        info = {
            "episode": self._episode_index,
            "start_ndist": start_ndist,
            "is_reversed": self._track.direction_reversed,
            "evaluation": self._evaluation,
            "start_time_s": self._episode_start_time_s,
        }
        return observation, info

    def _finish_episode(self) -> None:
        """End-of-episode bookkeeping (`StartRotation`)."""
        self._episode_open = False
        self._starts.finish(self._evaluation)

    def continue_after_lap(self, lap_start_time_s: float, *, renew_reset_budget: bool) -> None:
        """Keep an evaluation episode going across the finish line instead of starting a new one.

        DeepRacer's continuous evaluation and the summit rule drive lap after lap without returning to the line:
        progress restarts from 0, the lap clock restarts at `lap_start_time_s` (the crossing), the immobilized and
        reversed counters restart, and the reset budget is kept for the whole run or renewed per lap (summit rule).
        """
        if self._episode_open or self._last_status != EpisodeStatus.LAP_COMPLETE:
            raise RuntimeError("continue_after_lap() is only for an episode that has just ended with lap_complete")
        if not self._evaluation:
            raise RuntimeError("continue_after_lap() is for evaluation episodes; training episodes end at the line")
        self._episode_open = True
        self._episode_start_time_s = float(lap_start_time_s)
        pose = self._car.pose(self._data)
        self._phases.continue_after_lap((pose.origin_x_m, pose.origin_y_m), renew_reset_budget=renew_reset_budget)

    # ----- stepping ------------------------------------------------------------------------------------------

    def step(self, action: Any):
        """One camera period: judge the pose o_t shows (`PhaseMachine`), drive a_t (`_drive`), start rendering
        o_{t+1}, and while it renders compute the reward params, reward and simtrace row of the judged pose."""
        if not self._episode_open:
            raise RuntimeError("step() called before reset() or after the episode ended; call reset()")
        chosen = decode_action(self._metadata, action)
        track = self._track
        self._steps += 1.0
        # Judge the pose observation o_t was rendered at (the previous step computed it while rendering).
        pose, geometry, on_track = self._judge.judge(track)
        all_on, any_on = bool(on_track.all()), bool(on_track.any())
        now_s = float(self._data.time)
        bot_poses = self._track_objects.bot_poses() if self._track_objects is not None else []
        objects_time_s = now_s - self._objects_start_time_s
        verdict = self._phases.judge(pose, geometry, all_on=all_on, any_on=any_on, objects_time_s=objects_time_s)

        # The SimApp stamps a row when the step's physics has run (judge_action after unpausing), so the prepare
        # row is one step after the episode start and the last row's time is the lap's end.
        tstamp_s = self._drive(chosen, verdict)
        self._observer.start(self._data)

        # While the next frame renders: the pose it shows with its track geometry (the next step judges it),
        # then the reward and the simtrace row of the pose judged above.
        self._judge.judge(track)
        params = judged_reward_params(
            track, pose, geometry, chosen, verdict, all_on, any_on, self._steps, now_s, self._track_objects, bot_poses
        )
        reward = 0.0
        if verdict.run_step:
            reward = self._reward(params) if self._reward is not None else default_evaluation_reward(params)
        terminated = verdict.terminated
        truncated = not terminated and self._steps >= self._max_steps
        info = step_info(
            params,
            verdict,
            chosen,
            episode=self._episode_index,
            reward=reward,
            done=terminated or truncated,
            closest_waypoint=geometry.closest_waypoint_for_simtrace,
            tstamp_s=tstamp_s,
            obstacle_crash_counter=self._track_objects.obstacle_crash_count if self._track_objects is not None else 0,
            wall_clock_s=self._wall_clock(),
            evaluation=self._evaluation,
            lap_time_s=tstamp_s - self._episode_start_time_s if verdict.status == EpisodeStatus.LAP_COMPLETE else None,
        )
        self._last_status = verdict.status
        if terminated or truncated:
            self._finish_episode()
        return self._observer.finish(self._data, self.np_random, self._scene_rng), reward, terminated, truncated, info

    def _drive(self, chosen: ChosenAction, verdict: StepVerdict) -> float:
        """The physics of one camera period: the chosen command, or held where it is put back while paused; the
        objects move on. Returns the clock after it."""
        if verdict.hold_pose is not None:
            self._car.teleport(self._model, self._data, *verdict.hold_pose)
        command = self._episode_car.command(clip_command(chosen.speed_mps, chosen.steering_deg), verdict.drives)
        self._car.command(self._data, command[0], command[1])
        self._car.step(self._model, self._data, self._substeps)
        if self._track_objects is not None:
            self._track_objects.advance(float(self._data.time) - self._objects_start_time_s, self._scene_rng)
            self._place_objects()
        return float(self._data.time)

    def _place_objects(self) -> None:
        """Hand the objects' poses to the scene (bodies the cameras and LIDAR see)."""
        if self._object_bodies is not None and self._track_objects is not None:
            self._object_bodies.place(self._data, self._track_objects.objects)

    # ----- observations --------------------------------------------------------------------------------------

    def _observe(self) -> dict[str, np.ndarray]:
        self._observer.start(self._data)
        return self._observer.finish(self._data, self.np_random, self._scene_rng)

    def render(self) -> np.ndarray | None:
        """`rgb_array`: the front camera's RGB frame of the latest observation."""
        return self._observer.front_rgb(self._data) if self.render_mode == "rgb_array" else None

    def close(self) -> None:
        observer = getattr(self, "_observer", None)
        if observer is not None:
            observer.close()
            self._observer = self._camera = None  # type: ignore[assignment]

    # ----- test and tooling hooks ----------------------------------------------------------------------------

    def teleport(self, x_m: float, y_m: float, yaw_rad: float) -> None:
        """Put the car (origin) at rest at a pose; the next step judges that pose. For tests and tools."""
        self._car.teleport(self._model, self._data, x_m, y_m, yaw_rad)
