"""Code common to the trainer and the rollout and evaluation workers. Import name: `racer.shared`.

The repository's top-level folders install as subpackages of one `racer` namespace (setup.py's PACKAGE_DIRS):
this folder is `racer.shared`. `model_layout` owns the model folder's keys and checkpoint names; `config` is the only
reader of environment variables; `sim/` the MuJoCo simulator, `policy/` the networks and checkpoints, `deepracer/`
DeepRacer's file formats, `store/` S3/MinIO and local stores, `transport/` the Redis messages.
"""
