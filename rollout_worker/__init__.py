"""The rollout worker (DeepRacer's RoboMaker training job). Import name: `racer.rollout_worker`.

One worker simulates one world on several envs, claims episodes of each iteration (its own share first) and plays
them with the newest checkpoint, pushing each to Redis as it ends (`worker`), writing DeepRacer's simtrace and TrainingMetrics as it goes (`training_log`).
"""
