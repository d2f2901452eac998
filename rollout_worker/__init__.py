"""The rollout worker (DeepRacer's RoboMaker training job). Import name: `racer.rollout_worker`.

One worker simulates one world, plays its share of each iteration's episodes with the newest checkpoint and pushes
them to Redis (`worker`), writing DeepRacer's simtrace and TrainingMetrics as it goes (`training_log`).
"""
