"""The evaluation worker (DeepRacer's RoboMaker evaluation job): `racer evaluate`. Import name: `racer.evaluation_worker`.

Two ways to evaluate a stored model (best, last or a named checkpoint), greedy policy, any track/world/direction:

* `--mode deepracer` (`deepracer_eval`): NUMBER_OF_TRIALS, IS_CONTINUOUS, NUMBER_OF_RESETS, OFF_TRACK_PENALTY as the
  SimApp's evaluation job (deepracer-simapp v5.3.3 `bundle/markov/evaluation_worker.py`); DeepRacer's evaluation reward
  and termination statuses.
* `--mode race` (`summit_rule`): the AWS Summit physical-track rule -- 4 minutes of simulated time, lap after lap, up
  to 3 put-backs per lap, the 4th exit ends the lap attempt and the next one starts at the line.

Modules: `config` (frozen settings), `driver` (greedy policy + env + recorders), `laps` (per-lap tallies),
`deepracer_eval` / `summit_rule` (the two modes), `outputs` (layout, simtrace, EvaluationMetrics, summary, table),
`video` (MP4s), `mcap_recording` (Foxglove MCAP), `runner` (one evaluation end to end), `cli` (the click command).

Continuous runs (IS_CONTINUOUS, the summit rule's laps) keep the episode going after `lap_complete` with
`DeepRacerEnv.continue_after_lap` (lap clock and counters restart at the line; reset budget kept or renewed).
"""
