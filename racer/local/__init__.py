"""`racer train`: the local launcher. `run` plans and starts a run (Redis, the store, the trainer and the rollout
workers as local processes) and draws its display; `supervisor` restarts a worker that dies; `services` starts
redis-server and MinIO for it (and for the tests)."""
