"""The SageMaker side: DeepRacer's clipped-PPO trainer. Import name: `racer.trainer`.

`racer.trainer.ppo` (PPOTrainer.update, DeepRacer's log lines), `racer.trainer.gae`, `racer.trainer.nan_guard`,
`racer.trainer.bench` (`racer bench ppo`); the process loop is `racer.trainer.training_loop` / `racer.trainer.main`.
Networks and checkpoints live in `racer.shared.policy`, because the rollout and evaluation workers load them too.
"""
