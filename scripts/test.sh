#!/usr/bin/env bash
# Sets everything up (idempotent; with MinIO, which the S3 tests run against) and runs the whole test suite:
#   1. the linter and the formatter check (ruff, configured in pyproject.toml), first because they take a second,
#      then the documentation build (mkdocs build --strict: a broken link or a page missing from the nav fails);
#   2. the docker compose smoke test (scripts/compose-smoke-test.sh: builds the images without a registry,
#      trains two iterations in containers, checks MinIO, then the same on a single-node swarm);
#   3. pytest against real redis-server and MinIO processes, in three phases: every test not marked `heavy` or
#      `serial` on two pytest-xdist workers (most tests use one core); then the `heavy` ones (they start training
#      runs, a browser, a wheel build) two at a time, test by test, so that one's waits overlap the other's work; then
#      the `serial` ones (they assert a tight wall-time bound) one at a time; each phase ends with its 25 slowest
#      tests, and the script prints the whole run's time (goal: 20 minutes on 2 cores).
# RACER_TEST_DOCKER=0 skips step 2 (a quick local run); extra arguments make step 3 one plain pytest run with them,
# e.g. `-m "not slow"` for the fast loop (docs/getting-started.md).
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh --with-minio
export PATH="$PWD/.venv/bin:$PATH"
export MUJOCO_GL="${MUJOCO_GL:-egl}"
echo "[test] ruff check, ruff format --check"
.venv/bin/ruff check .
.venv/bin/ruff format --check .
echo "[test] mkdocs build --strict (documentation: broken links fail)"
NO_MKDOCS_2_WARNING=1 .venv/bin/python -m mkdocs build --strict --site-dir "$(mktemp -d)"
if [ "${RACER_TEST_DOCKER:-1}" != "0" ]; then
  ./scripts/compose-smoke-test.sh
fi
if [ "$#" -gt 0 ]; then
  exec .venv/bin/python -m pytest --durations=25 "$@"
fi
SECONDS=0
echo "[test] pytest, phase 1 of 3: the tests marked neither heavy nor serial, on two workers"
.venv/bin/python -m pytest -n 2 --dist loadscope -m "not heavy and not serial" --durations=25
parallel_s=$SECONDS
echo "[test] pytest, phase 2 of 3: the heavy tests, two at a time"
.venv/bin/python -m pytest -n 2 --dist load -m "heavy and not serial" --durations=25
heavy_s=$((SECONDS - parallel_s))
echo "[test] pytest, phase 3 of 3: the serial tests, one at a time"
.venv/bin/python -m pytest -m serial --durations=25
serial_s=$((SECONDS - parallel_s - heavy_s))
echo "[test] pytest took $((SECONDS / 60)) min $((SECONDS % 60)) s (phase 1 ${parallel_s} s, phase 2 ${heavy_s} s," \
  "phase 3 ${serial_s} s; goal 20 min)"
