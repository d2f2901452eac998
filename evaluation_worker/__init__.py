"""The evaluation worker (DeepRacer's RoboMaker evaluation job): `racer evaluate`.

Two ways to evaluate a stored model (best, last or a named checkpoint), greedy policy, any track/world/direction:

* `--mode deepracer` (`deepracer_eval`): NUMBER_OF_TRIALS, IS_CONTINUOUS, NUMBER_OF_RESETS, OFF_TRACK_PENALTY as the
  SimApp's evaluation job (reference §3.1); DeepRacer's evaluation reward and termination statuses.
* `--mode race` (`race_rule`): the AWS Summit physical-track rule -- 4 minutes of simulated time, lap after lap, up
  to 3 put-backs per lap, the 4th exit ends the lap attempt and the next one starts at the line.

Modules: `config` (frozen settings), `driver` (greedy policy + env + recorders), `laps` (per-lap tallies),
`deepracer_eval` / `race_rule` (the two modes), `outputs` (layout, simtrace, EvaluationMetrics, summary, table),
`video` (MP4s), `mcap_recording` (Foxglove MCAP), `runner` (one evaluation end to end), `main` (the click command).

Env dependency. Continuous runs (IS_CONTINUOUS, race laps) need the episode to go on after `lap_complete`;
`DeepRacerEnv` ends it, so `EvaluationDriver.continue_after_lap` reopens it through four of the env's attributes
(`_episode_open`, `_episode_start_time_s`, `_reset_count`, `_counters`) and fails with a clear error if they go away.
The small env change that would replace this: `EnvConfig.is_continuous` (keep the episode open on lap_complete,
restart the lap clock and the immobilized/reversed counters at the line) plus a way to renew the reset budget
(`env.renew_reset_budget()`), i.e. what the SimApp's `_metrics.reset(); _reset_rules_manager.reset()` does.
"""
