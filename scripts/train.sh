#!/usr/bin/env bash
# Sets up what training needs (idempotent; no Go, no MinIO) and trains with the embedded default: local
# processes, a Redis server, storage in ./racer-data, four rollout workers (base, carpet, concrete, wood).
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh
export PATH="$PWD/.venv/bin:$PATH"
exec .venv/bin/racer train "$@"
