#!/usr/bin/env bash
# Sets everything up (idempotent) and runs the whole test suite against real Redis and MinIO servers.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh
export PATH="$PWD/.venv/bin:$PATH"
export MUJOCO_GL="${MUJOCO_GL:-egl}"
exec .venv/bin/python -m pytest "$@"
