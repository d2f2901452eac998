#!/usr/bin/env bash
# Sets everything up (idempotent) and runs the whole test suite:
#   1. the linter and the formatter check (ruff, configured in pyproject.toml), first because they take a second,
#      then the documentation build (mkdocs build --strict: a broken link or a page missing from the nav fails);
#   2. the docker compose smoke test (scripts/compose-smoke-test.sh: builds the images without a registry,
#      trains two iterations in containers, checks MinIO, then the same on a single-node swarm);
#   3. pytest against real redis-server and MinIO processes, ending with the 25 slowest tests and their times.
# RACER_TEST_DOCKER=0 skips step 2 (a quick local run); extra arguments go to pytest, e.g. `-m "not slow"` for the
# fast loop (docs/getting-started.md).
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh
export PATH="$PWD/.venv/bin:$PATH"
export MUJOCO_GL="${MUJOCO_GL:-egl}"
echo "[test] ruff check, ruff format --check"
.venv/bin/ruff check .
.venv/bin/ruff format --check .
echo "[test] mkdocs build --strict (documentation: broken links fail)"
NO_MKDOCS_2_WARNING=1 .venv/bin/mkdocs build --strict --site-dir "$(mktemp -d)"
if [ "${RACER_TEST_DOCKER:-1}" != "0" ]; then
  ./scripts/compose-smoke-test.sh
fi
exec .venv/bin/python -m pytest --durations=25 "$@"
