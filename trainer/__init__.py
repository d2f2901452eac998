"""The SageMaker side: DeepRacer's clipped-PPO and SAC trainers. Import name: `racer.trainer`.

`racer.trainer.preflight` (custom files checked before anything starts), `racer.trainer.ppo` (PPOLearner.update,
DeepRacer's log lines), `racer.trainer.sac` (SACLearner.update) with `racer.trainer.replay_buffer` (its replay memory),
`racer.trainer.gae`, `racer.trainer.nan_guard`; the process loop is `racer.trainer.training_loop` / `racer.trainer.cli`,
with the run's files (`racer.trainer.run_files`), the iteration summary (`racer.trainer.iteration_summary`), the
iteration's writes (`racer.trainer.iteration_finish`) and their timers (`racer.trainer.iteration_parts`), and the
stop signals and time limit (`racer.trainer.stopping`) beside it.
Networks and checkpoints live in `racer.shared.policy`, because the rollout and evaluation workers load them too.

The trainer saves every checkpoint but does not choose the best one: choosing needs greedy laps in an env, and the
trainer has none. Rollout worker 0 evaluates each new checkpoint (racer.rollout_worker.checkpoint_evaluation) and
records the best and the last in `model/deepracer_checkpoints.json` (racer.rollout_worker.training_log with
racer.shared.policy.best_and_last, DeepRacer's rule), as the SimApp's rollout worker does.
The trainer's benches (`python -m benchmarks ppo`, `python -m benchmarks sac`) live in `benchmarks`.
"""
