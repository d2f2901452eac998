#!/usr/bin/env bash
# Compose smoke test: builds every image without a container registry (racer's two: the worker image
# without torch and the trainer image with it, whose sizes it prints), runs `docker compose up`
# for two training iterations with two workers in two worlds (base, carpet) on the short
# racer_oval track, checks what the run left in MinIO and the trainer's log, runs the evaluation,
# analysis and race services, loads the viewer service's page and script over HTTP, then `down -v`.
# Then the same run with the same file on a single-node swarm (`docker stack deploy`), same checks.
#
#   scripts/compose-smoke-test.sh          # exit 0: passed; non-zero: failed (the reason is printed last)
#
# On a machine without a running Docker engine it installs docker.io (+ docker-compose when no
# compose is available) and starts dockerd, when run as root; a dockerd it started is stopped at
# the end. Images are built from a local Debian base image (docker/build-base-image.sh), so only the
# Debian and PyPI package registries are needed. Measured on 2 shared cores: 8.5 minutes with no image
# cached (+1 minute to install docker.io), about 2 minutes with cached images.
#
# Environment (all optional):
#   SMOKE_BASE_IMAGE     base image for every build (default racer-base:bookworm, built here when missing)
#   SMOKE_PIP_CERT       CA bundle inside the build for pip (default /etc/ssl/certs/host-ca-bundle.crt,
#                        which build-base-image.sh puts in the local base image; empty with an official base)
#   MINIO_BINARY         MinIO server binary for the local MinIO image (default: the one scripts/install-minio.sh
#                        finds, or builds when there is none)
#   SMOKE_MINIO_PORT     host port (loopback) the test publishes MinIO's API on, the console on the next one
#                        (default: the first free pair from 19000)
#   SMOKE_COMPOSE        compose command (default `docker compose` when the v2 plugin is there, else `docker-compose`)
#   SMOKE_TRAIN_TIMEOUT_S  longest wait for the training run (default 900)
#   SMOKE_BUILD_TIMEOUT_S  longest one image build may take (default 1800; torch is a large download)
#   SMOKE_SWARM=0        skip the second part: the same run on a single-node swarm (docker stack deploy);
#                        it runs only on an engine that is not in a swarm yet, and leaves the swarm after
#   SMOKE_KEEP=1         leave the compose project (or the stack) up after the test (for debugging)
#   SMOKE_KEEP_DOCKERD=1 leave a dockerd this script started running
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT="$PWD"

# Values from the caller's environment would override the test's env file in compose: drop them.
for name in $(compgen -v | grep -E '^(RACER_|MINIO_(ROOT|IMAGE|PUBLISH|API|CONSOLE)|REDIS_IMAGE$|S3_ENDPOINT_URL$|AWS_DEFAULT_REGION$|MUJOCO_GL$|COMPOSE_)' || true); do
  unset "$name"
done

PROJECT=racersmoke
STACK=racersmokestack
PREFIX=smoke-model
BUCKET=racer-smoke
BASE_IMAGE="${SMOKE_BASE_IMAGE:-racer-base:bookworm}"
PIP_CERT_IN_BUILD="${SMOKE_PIP_CERT-/etc/ssl/certs/host-ca-bundle.crt}"
WORKER_IMAGE=racer-worker:local
TRAINER_IMAGE=racer-trainer:local
WORKER_IMAGE_LIMIT_BYTES=1500000000  # issue 31: the image of a node that only runs workers stays <= 1.5 GB
REDIS_IMAGE=racer-redis:local
MINIO_IMAGE=racer-minio:local
port_in_use() { (exec 3<>"/dev/tcp/127.0.0.1/$1") 2>/dev/null; }
if [ -n "${SMOKE_MINIO_PORT:-}" ]; then
  MINIO_PORT="$SMOKE_MINIO_PORT"
else  # the first pair of free loopback ports from 19000 (API, console = API + 1)
  MINIO_PORT=19000
  while port_in_use "$MINIO_PORT" || port_in_use "$((MINIO_PORT + 1))"; do
    MINIO_PORT=$((MINIO_PORT + 2))
    [ "$MINIO_PORT" -lt 19200 ] || { echo "[smoke] no free port pair in 19000-19199 for MinIO" >&2; exit 1; }
  done
fi
VIEWER_PORT=18100  # the live page's loopback port: the first free one from 18100
while port_in_use "$VIEWER_PORT"; do
  VIEWER_PORT=$((VIEWER_PORT + 1))
  [ "$VIEWER_PORT" -lt 18200 ] || { echo "[smoke] no free port in 18100-18199 for the viewer" >&2; exit 1; }
done
TRAIN_TIMEOUT_S="${SMOKE_TRAIN_TIMEOUT_S:-900}"
BUILD_TIMEOUT_S="${SMOKE_BUILD_TIMEOUT_S:-1800}"
RUN_TIMEOUT_S=600  # one `compose run` (evaluation or analysis)

T0=$SECONDS
STEP_T0=$SECONDS
WORK="$(mktemp -d /tmp/racer-compose-smoke.XXXXXX)"
STARTED_DOCKERD_PID=""
STARTED_SWARM=""
SWARM_PASSED=""
COMPOSE_DOWN_DONE=""
COMPOSE=()

say() { printf '[smoke %4ds] %s\n' "$((SECONDS - T0))" "$*"; }
step() { STEP_T0=$SECONDS; say "$*"; }
done_step() { say "  done in $((SECONDS - STEP_T0)) s${1:+: $1}"; }
fail() {
  printf '\n[smoke] FAILED after %d s: %s\n' "$((SECONDS - T0))" "$*" >&2
  exit 1
}


# compose ARGS...: the test's project; COMPOSE_LIMIT_S=N compose ARGS... gives up after N seconds.
compose() { ${COMPOSE_LIMIT_S:+timeout "$COMPOSE_LIMIT_S"} "${COMPOSE[@]}" --project-name "$PROJECT" \
  --env-file "$WORK/smoke.env" -f "$ROOT/docker-compose.yml" -f "$ROOT/docker/compose.ports.yml" "$@"; }

remove_swarm() {  # the stack, its volume, and the single-node swarm this test created
  docker stack rm "$STACK" >/dev/null 2>&1 || true
  for _ in $(seq 1 120); do  # stack rm returns at once; its containers stop within a few seconds
    [ -z "$(docker ps -aq --filter "label=com.docker.stack.namespace=$STACK")" ] && break
    sleep 0.5
  done
  docker volume rm "${STACK}_minio-data" >/dev/null 2>&1 || true
  docker swarm leave --force >/dev/null 2>&1 || true
  STARTED_SWARM=""
  SWARM_PASSED=1
}

cleanup() {
  local status=$?
  if [ -n "$STARTED_SWARM" ]; then
    if [ "$status" -ne 0 ]; then
      say "--- last swarm logs (trainer, rollout-0) ---"
      for service in trainer rollout-0; do
        docker service logs --raw --tail 40 "${STACK}_$service" 2>&1 | sed 's/^/    /' || true
      done
    fi
    [ "${SMOKE_KEEP:-0}" = 1 ] && say "SMOKE_KEEP=1: stack $STACK and the swarm left up" || remove_swarm
  fi
  if [ -z "$COMPOSE_DOWN_DONE" ] && [ ${#COMPOSE[@]} -gt 0 ] && [ -f "$WORK/smoke.env" ]; then
    if [ "$status" -ne 0 ]; then
      say "--- last compose logs (trainer, rollout-0, rollout-1, minio-setup) ---"
      compose logs --no-color --tail=40 trainer rollout-0 rollout-1 minio-setup 2>&1 | sed 's/^/    /' || true
    fi
    if [ "${SMOKE_KEEP:-0}" = 1 ]; then
      say "SMOKE_KEEP=1: project $PROJECT left up (env file $WORK/smoke.env)"
    else
      compose down -v --remove-orphans >"$WORK/down.log" 2>&1 || say "warning: compose down failed (see $WORK/down.log)"
    fi
  fi
  if [ -n "$STARTED_DOCKERD_PID" ] && [ "${SMOKE_KEEP_DOCKERD:-0}" != 1 ] && [ "${SMOKE_KEEP:-0}" != 1 ]; then
    kill "$STARTED_DOCKERD_PID" 2>/dev/null || true
    wait "$STARTED_DOCKERD_PID" 2>/dev/null || true
  fi
  [ "${SMOKE_KEEP:-0}" = 1 ] || [ "$status" -ne 0 ] || rm -rf "$WORK"
  [ "$status" -eq 0 ] || say "work files kept in $WORK"
}
trap cleanup EXIT

as_root_install() {
  [ "$(id -u)" -eq 0 ] || fail "$1 is missing and this script is not root: install it (apt-get install $2)"
  say "installing $2 (apt-get)"
  apt-get update -qq >/dev/null
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "$2" >"$WORK/apt-$2.log" 2>&1 \
    || { tail -20 "$WORK/apt-$2.log" >&2; fail "apt-get install $2 failed"; }
}

# --- 1. Docker engine and compose --------------------------------------------------------------------
step "checking the Docker engine"
command -v dockerd >/dev/null 2>&1 || as_root_install dockerd docker.io
command -v docker >/dev/null 2>&1 || as_root_install docker docker.io
if ! docker info >/dev/null 2>&1; then
  [ "$(id -u)" -eq 0 ] || fail "no Docker engine answers and this script is not root to start dockerd"
  say "starting dockerd (log: $WORK/dockerd.log)"
  dockerd >"$WORK/dockerd.log" 2>&1 &
  STARTED_DOCKERD_PID=$!
  for _ in $(seq 1 60); do  # engine start-up: up to 30 s
    docker info >/dev/null 2>&1 && break
    kill -0 "$STARTED_DOCKERD_PID" 2>/dev/null || { tail -20 "$WORK/dockerd.log" >&2; fail "dockerd exited at start"; }
    sleep 0.5
  done
  docker info >/dev/null 2>&1 || { tail -20 "$WORK/dockerd.log" >&2; fail "dockerd did not answer within 30 s"; }
fi
if [ -n "${SMOKE_COMPOSE:-}" ]; then
  read -r -a COMPOSE <<<"$SMOKE_COMPOSE"
  "${COMPOSE[@]}" version >/dev/null 2>&1 || fail "SMOKE_COMPOSE='$SMOKE_COMPOSE' does not run"
elif docker compose version >/dev/null 2>&1; then
  COMPOSE=(docker compose)
else
  command -v docker-compose >/dev/null 2>&1 || as_root_install docker-compose docker-compose
  COMPOSE=(docker-compose)
fi
done_step "engine $(docker version -f '{{.Server.Version}}'), compose: ${COMPOSE[*]} ($("${COMPOSE[@]}" version --short 2>/dev/null || echo '?'))"

# --- 2. Images --------------------------------------------------------------------------------------
build_image() {  # build_image LOG_NAME docker-build-args...
  local log="$WORK/build-$1.log"; shift
  if ! timeout "$BUILD_TIMEOUT_S" docker build "$@" >"$log" 2>&1; then
    tail -40 "$log" >&2
    fail "docker build $* failed (full log: $log)"
  fi
}

if [ "$BASE_IMAGE" = racer-base:bookworm ]; then
  step "base image $BASE_IMAGE (debootstrap + docker import when missing)"
  docker/build-base-image.sh "$BASE_IMAGE" >"$WORK/base-image.log" 2>&1 || { tail -30 "$WORK/base-image.log" >&2; fail "building the base image failed"; }
  done_step
fi

image_size() { docker image inspect -f '{{.Size}}' "$1"; }
gigabytes() { awk '{printf "%.2f GB", $1/1e9}' <<<"$1"; }
step "racer images from docker/Dockerfile: $WORKER_IMAGE (target worker), $TRAINER_IMAGE (target trainer; torch download the first time)"
build_image worker -f docker/Dockerfile --target worker --build-arg BASE_IMAGE="$BASE_IMAGE" \
  --build-arg PIP_CERT="$PIP_CERT_IN_BUILD" -t "$WORKER_IMAGE" .
build_image trainer -f docker/Dockerfile --target trainer --build-arg BASE_IMAGE="$BASE_IMAGE" \
  --build-arg PIP_CERT="$PIP_CERT_IN_BUILD" -t "$TRAINER_IMAGE" .
# A rebuild after a dependency change leaves the previous image untagged (7 GB): remove those, and only those.
docker image prune -f --filter label=racer.image=racer >/dev/null || true
worker_bytes="$(image_size "$WORKER_IMAGE")"
trainer_bytes="$(image_size "$TRAINER_IMAGE")"
say "  image sizes: worker $WORKER_IMAGE $(gigabytes "$worker_bytes") ($worker_bytes bytes), trainer $TRAINER_IMAGE $(gigabytes "$trainer_bytes") ($trainer_bytes bytes)"
[ "$worker_bytes" -le "$WORKER_IMAGE_LIMIT_BYTES" ] \
  || fail "the worker image is $(gigabytes "$worker_bytes"), over $(gigabytes "$WORKER_IMAGE_LIMIT_BYTES")"
docker run --rm --entrypoint python3 "$WORKER_IMAGE" -c 'import importlib.util as u, sys; sys.exit(1 if u.find_spec("torch") else 0)' \
  || fail "the worker image $WORKER_IMAGE has torch installed"
done_step "worker $(gigabytes "$worker_bytes"), trainer $(gigabytes "$trainer_bytes")"

step "redis and minio images from docker/services.Dockerfile"
minio_bin="${MINIO_BINARY:-}"
if [ -z "$minio_bin" ]; then
  minio_bin="$(readlink -f "$(PATH="$ROOT/.venv/bin:$PATH" scripts/install-minio.sh)")" \
    || fail "no MinIO binary: scripts/install-minio.sh failed (or set MINIO_BINARY)"
fi
mkdir -p "$WORK/minio-context" "$WORK/empty-context"
cp "$minio_bin" "$WORK/minio-context/minio"
chmod 0755 "$WORK/minio-context/minio"
build_image redis -f docker/services.Dockerfile --target redis --build-arg BASE_IMAGE="$BASE_IMAGE" -t "$REDIS_IMAGE" "$WORK/empty-context"
build_image minio -f docker/services.Dockerfile --target minio --build-arg BASE_IMAGE="$BASE_IMAGE" -t "$MINIO_IMAGE" "$WORK/minio-context"
rm -f "$WORK/minio-context/minio"
done_step

# --- 3. Training run -----------------------------------------------------------------------------
# The user's folder: the project's defaults, with a tiny iteration (2 episodes: one per worker) and
# one evaluation trial per checkpoint, so that two iterations take about a minute.
mkdir -p "$WORK/custom_files"
cp racer/defaults/custom_files/reward_function.py racer/defaults/custom_files/model_metadata.json "$WORK/custom_files/"
cat >"$WORK/custom_files/hyperparameters.json" <<'EOF'
{"num_episodes_between_training": 2, "batch_size": 32, "num_epochs": 3}
EOF
echo '{"MIN_EVAL_TRIALS": 1}' >"$WORK/custom_files/workers.json"
chmod -R a+rX "$WORK/custom_files"

cat >"$WORK/smoke.env" <<EOF
MINIO_ROOT_USER=smoke-admin
MINIO_ROOT_PASSWORD=smoke-$(od -An -N8 -tx1 /dev/urandom | tr -d ' \n')
RACER_S3_ACCESS_KEY=smoke-services
RACER_S3_SECRET_KEY=smoke-$(od -An -N8 -tx1 /dev/urandom | tr -d ' \n')
RACER_MODEL_PREFIX=$PREFIX
RACER_BUCKET=$BUCKET
RACER_CUSTOM_FILES=$WORK/custom_files
RACER_WORKERS=2
RACER_TRACK=racer_oval
RACER_WORLDS=base,carpet
RACER_TRAINER_ARGS=--max-episodes 4
RACER_ROLLOUT_ARGS=--wait-timeout-s 600
RACER_EVAL_ARGS=--checkpoint last --trials 1 --no-video --no-mcap
RACER_ANALYSIS_OUT=$WORK/analysis
RACER_UID=$(id -u)
RACER_GID=$(id -g)
RACER_WORKER_IMAGE=$WORKER_IMAGE
RACER_TRAINER_IMAGE=$TRAINER_IMAGE
REDIS_IMAGE=$REDIS_IMAGE
MINIO_IMAGE=$MINIO_IMAGE
MINIO_PUBLISH_ADDRESS=127.0.0.1
MINIO_API_PORT=$MINIO_PORT
MINIO_CONSOLE_PORT=$((MINIO_PORT + 1))
RACER_VIEWER_PORT=$VIEWER_PORT
EOF

step "removing what an earlier smoke run may have left (project $PROJECT)"
compose down -v --remove-orphans >"$WORK/down-before.log" 2>&1 || true
done_step

step "docker compose up -d trainer rollout-0 rollout-1 (2 workers: base, carpet; 2 iterations of 2 episodes)"
compose up -d --no-build trainer rollout-0 rollout-1 >"$WORK/up.log" 2>&1 || { cat "$WORK/up.log" >&2; fail "docker compose up failed"; }
compose ps
for service in redis minio; do
  health="$(docker inspect -f '{{.State.Health.Status}}' "$(compose ps -a -q "$service")")"
  [ "$health" = healthy ] || fail "$service is $health after up (up waits for healthy)"
done
setup_exit="$(docker inspect -f '{{.State.ExitCode}}' "$(compose ps -a -q minio-setup)")"
[ "$setup_exit" = 0 ] || fail "minio-setup exited with $setup_exit"
# Published only through docker/compose.ports.yml, on loopback: check that MinIO answers there.
exec 3<>"/dev/tcp/127.0.0.1/$MINIO_PORT" || fail "MinIO is not reachable on the published port 127.0.0.1:$MINIO_PORT"
printf 'GET /minio/health/live HTTP/1.1\r\nHost: localhost\r\nConnection: close\r\n\r\n' >&3
timeout 10 head -n1 <&3 | grep -q ' 200 ' || fail "MinIO on 127.0.0.1:$MINIO_PORT did not answer its health check"
exec 3<&-
# Each service runs the image it belongs to: torch only in the trainer's.
for service in trainer rollout-0 rollout-1 minio-setup; do
  expected="$WORKER_IMAGE"; [ "$service" = trainer ] && expected="$TRAINER_IMAGE"
  actual="$(docker inspect -f '{{.Config.Image}}' "$(compose ps -a -q "$service")")"
  [ "$actual" = "$expected" ] || fail "$service runs image $actual, expected $expected"
done
# Redis must not be published.
[ -z "$(docker port "$(compose ps -a -q redis)")" ] || fail "redis has a published port: $(docker port "$(compose ps -a -q redis)")"
done_step "redis, minio healthy; bucket set up; MinIO published on 127.0.0.1:$MINIO_PORT only"

step "waiting for the trainer to finish (at most $TRAIN_TIMEOUT_S s)"
trainer_id="$(compose ps -a -q trainer)"
trainer_exit="$(timeout "$TRAIN_TIMEOUT_S" docker wait "$trainer_id" || echo timeout)"
compose logs --no-color trainer >"$WORK/trainer.log" 2>&1 || true
[ "$trainer_exit" != timeout ] || fail "the trainer did not finish within $TRAIN_TIMEOUT_S s (log: $WORK/trainer.log)"
[ "$trainer_exit" = 0 ] || fail "the trainer exited with status $trainer_exit (log: $WORK/trainer.log)"
done_step
step "waiting for the rollout workers to exit after the run (at most 120 s)"
for service in rollout-0 rollout-1; do
  worker_exit="$(timeout 120 docker wait "$(compose ps -a -q "$service")" || echo timeout)"
  compose logs --no-color "$service" >"$WORK/$service.log" 2>&1 || true
  [ "$worker_exit" = 0 ] || fail "$service exited with status $worker_exit after the run (log: $WORK/$service.log)"
done
done_step

# --- 4. Checks (shared by the compose and the swarm run) -------------------------------------------
check_trainer_log() {  # check_trainer_log LOGFILE
  for worker in 0 1; do
    grep -Eq "Training> Name=main_level/agent, Worker=$worker, Episode=[0-9]+, Total reward=[-0-9.e]+, Steps=[0-9]+, Training iteration=[0-9]+" "$1" \
      || fail "the trainer log has no 'Training> ... Worker=$worker' episode line (log: $1)"
  done
  say "  trainer log: $(grep -c 'Training> Name=main_level/agent' "$1") episode lines, from workers 0 (base) and 1 (carpet)"
}

check_store() {  # check_store NETWORK ENV_FILE: reads MinIO from inside that network with the image's boto3
  local env_file="$2" log="$WORK/store-check-$1-${3:-training}.log"
  docker run --rm -i --network "$1" --entrypoint python3 -e CHECK="${3:-training}" \
    -e S3_ENDPOINT_URL=http://minio:9000 -e AWS_DEFAULT_REGION=us-east-1 \
    -e AWS_ACCESS_KEY_ID="$(grep '^MINIO_ROOT_USER=' "$env_file" | cut -d= -f2-)" \
    -e AWS_SECRET_ACCESS_KEY="$(grep '^MINIO_ROOT_PASSWORD=' "$env_file" | cut -d= -f2-)" \
    -e BUCKET="$(grep '^RACER_BUCKET=' "$env_file" | cut -d= -f2-)" \
    -e PREFIX="$(grep '^RACER_MODEL_PREFIX=' "$env_file" | cut -d= -f2-)" \
    "$WORKER_IMAGE" - >"$log" 2>&1 <<'PY' || { cat "$log" >&2; fail "the store check (${3:-training}) failed: see above"; }
import os, re, sys
import boto3

s3 = boto3.client("s3", endpoint_url=os.environ["S3_ENDPOINT_URL"])
bucket, prefix = os.environ["BUCKET"], os.environ["PREFIX"]
keys = set()
for page in s3.get_paginator("list_objects_v2").paginate(Bucket=bucket, Prefix=prefix + "/"):
    keys.update(item["Key"] for item in page.get("Contents", []))
problems = []
def need(key, why):
    if key not in keys:
        problems.append(f"missing {key} ({why})")
checkpoint = re.compile(r"^(\d+)_Step-(\d+)\.ckpt")
numbers = sorted({int(m.group(1)) for k in keys if k.startswith(f"{prefix}/model/")
                  for m in [checkpoint.match(k.rsplit("/", 1)[1])] if m})
if numbers[-1:] != [2]:
    problems.append(f"checkpoints {numbers}: expected the last to be 2 (checkpoint 0 + two iterations)")
if os.environ["CHECK"] == "evaluation":  # after `docker compose --profile evaluation run evaluation`
    metrics = [k for k in keys if re.fullmatch(re.escape(prefix) + r"/metrics/evaluation/evaluation-\d{14}\.json", k)]
    simtraces = [k for k in keys if re.fullmatch(re.escape(prefix) + r"/evaluation-\d{14}/evaluation-simtrace/0-iteration\.csv", k)]
    if not metrics or not simtraces:
        sys.exit(f"no evaluation output under s3://{bucket}/{prefix}/: metrics {metrics}, simtraces {simtraces}")
    print(f"evaluation: {metrics[0]}, {simtraces[0]}")
    sys.exit(0)
need(f"{prefix}/model/.coach_checkpoint", "the checkpoint pointer")
if f"{prefix}/model/.coach_checkpoint" in keys:
    pointer = s3.get_object(Bucket=bucket, Key=f"{prefix}/model/.coach_checkpoint")["Body"].read().decode().strip()
    match = checkpoint.match(pointer)
    if not match or match.group(1) != "2":
        problems.append(f".coach_checkpoint names {pointer!r}, expected checkpoint 2")
    else:
        print(f"pointer: {pointer}")
need(f"{prefix}/model/.finished", "written at the end of training")
need(f"{prefix}/model/model_metadata.json", "the action space")
need(f"{prefix}/reward_function.py", "uploaded from custom_files")
need(f"{prefix}/ip/hyperparameters.json", "uploaded from custom_files")
for worker, world in ((0, "base"), (1, "carpet")):
    for iteration in (0, 1):
        need(f"{prefix}/{worker}/training-simtrace/{iteration}-iteration.csv", f"simtrace of worker {worker} ({world})")
params = {0: "training_params.yaml", 1: "training_params_1.yaml"}
for worker, world in ((0, "base"), (1, "carpet")):
    key = f"{prefix}/{params[worker]}"
    if key in keys:
        text = s3.get_object(Bucket=bucket, Key=key)["Body"].read().decode()
        if world not in text:
            problems.append(f"{key} does not name world {world}")
    else:
        problems.append(f"missing {key} (worker {worker}'s settings)")
need(f"{prefix}/metrics/TrainingMetrics.json", "worker 0 metrics")
print(f"{len(keys)} objects under s3://{bucket}/{prefix}/; checkpoints {numbers}")
if problems:
    print("\n".join(problems), file=sys.stderr)
    sys.exit(1)
PY
  sed 's/^/  /' "$log"
}

step "checking the trainer log and the store"
check_trainer_log "$WORK/trainer.log"
network="$(docker inspect -f '{{range $name, $_ := .NetworkSettings.Networks}}{{$name}} {{end}}' "$(compose ps -a -q minio)" | awk '{print $1}')"
check_store "$network" "$WORK/smoke.env"
done_step

step "docker compose --profile evaluation run --rm evaluation (last checkpoint, 1 trial)"
COMPOSE_LIMIT_S="$RUN_TIMEOUT_S" compose --profile evaluation run -T --rm evaluation >"$WORK/evaluation.log" 2>&1 \
  || { tail -30 "$WORK/evaluation.log" >&2; fail "the evaluation service failed (log: $WORK/evaluation.log)"; }
done_step
step "docker compose --profile analysis run --rm analysis"
mkdir -p "$WORK/analysis"
COMPOSE_LIMIT_S="$RUN_TIMEOUT_S" compose --profile analysis run -T --rm analysis >"$WORK/analysis.log" 2>&1 \
  || { tail -30 "$WORK/analysis.log" >&2; fail "the analysis service failed (log: $WORK/analysis.log)"; }
[ -s "$WORK/analysis/report.html" ] || fail "the analysis service wrote no report.html into RACER_ANALYSIS_OUT ($WORK/analysis)"
done_step "report.html and $(find "$WORK/analysis" -type f | wc -l) files"
step "checking the evaluation's files in the store"
check_store "$network" "$WORK/smoke.env" evaluation
done_step

step "docker compose --profile race run --rm race (the trained model and a missing one, 1 lap of racer_oval)"
mkdir -p "$WORK/races"
cat >"$WORK/races/race.yaml" <<'EOF'
name: smoke-cup
trackConfig: {trackId: racer_oval}
raceType: TIME_TRIAL
timingMethod: BEST_LAP_TIME
submissionTerminationConditions: {minimumLaps: 1, maximumLaps: 1, maxTimeInMinutes: 1}
maxResets: 0
EOF
echo "RACER_RACES=$WORK/races" >>"$WORK/smoke.env"
COMPOSE_LIMIT_S="$RUN_TIMEOUT_S" compose --profile race run -T --rm race \
  race races/race.yaml "$PREFIX" no-such-model --no-video --workers 1 >"$WORK/race.log" 2>&1 \
  || { tail -30 "$WORK/race.log" >&2; fail "the race service failed (log: $WORK/race.log)"; }
BOARD="$WORK/races/smoke-cup/leaderboard.json" PREFIX="$PREFIX" python3 - <<'PY' \
  || fail "the race's leaderboard is not what the race file and the entrants ask for (log: $WORK/race.log)"
import json, os, sys
board = json.load(open(os.environ["BOARD"]))
rows = {row["entrant"]: row for row in board["leaderboard"]}
if set(rows) != {os.environ["PREFIX"], "no-such-model"}:
    sys.exit(f"entrants on the board: {sorted(rows)}")
trained, missing = rows[os.environ["PREFIX"]], rows["no-such-model"]
if trained["checkpoint"] is None or trained["lapCount"] != 1:
    sys.exit(f"the trained model's row: {json.dumps(trained)[:600]}")
if missing["errorCode"] != "FILE_DOES_NOT_EXIST":
    sys.exit(f"the missing entrant's row: {missing}")
PY
[ -s "$WORK/races/smoke-cup/leaderboard.html" ] || fail "the race service wrote no leaderboard.html"
done_step "a board of 2 rows (the missing entrant with FILE_DOES_NOT_EXIST)"

step "docker compose up -d viewer: the page, its script from the image and the run over HTTP (127.0.0.1:$VIEWER_PORT)"
compose up -d --no-build viewer >"$WORK/viewer-up.log" 2>&1 || { cat "$WORK/viewer-up.log" >&2; fail "docker compose up viewer failed"; }
viewer_url="http://127.0.0.1:$VIEWER_PORT"
for _ in $(seq 1 60); do
  curl -fsS -o "$WORK/viewer.html" "$viewer_url/" 2>/dev/null && break
  sleep 1
done
grep -q '/static/viewer.js' "$WORK/viewer.html" 2>/dev/null \
  || fail "the viewer's page did not load from $viewer_url/ (docker compose -p $PROJECT logs viewer)"
curl -fsS -o "$WORK/viewer.js" "$viewer_url/static/viewer.js" \
  || fail "$viewer_url/static/viewer.js failed: the image lacks racer/viewer/static"
curl -fsS "$viewer_url/api/run" | grep -q "\"model\": *\"$PREFIX\"" \
  || fail "$viewer_url/api/run does not name the model $PREFIX"
done_step "index.html, viewer.js ($(wc -c <"$WORK/viewer.js") bytes), /api/run names $PREFIX"

step "docker compose down -v"
compose down -v --remove-orphans >"$WORK/down.log" 2>&1 || { cat "$WORK/down.log" >&2; fail "docker compose down -v failed"; }
COMPOSE_DOWN_DONE=1
done_step
COMPOSE_SECONDS=$((SECONDS - T0))

# --- 5. The same file on a single-node swarm (docker stack deploy) ------------------------------------
# Only on an engine that is not in a swarm yet (the test makes it a single-node swarm and leaves it
# afterwards); an engine already in a swarm is left alone. SMOKE_SWARM=0 skips this part.
swarm_state="$(docker info -f '{{.Swarm.LocalNodeState}}')"
if [ "$swarm_state" = active ] && [ "$(docker info -f '{{.Swarm.Nodes}}')" = 1 ] \
   && docker stack ls --format '{{.Name}}' 2>/dev/null | grep -qx "$STACK"; then
  say "removing the single-node swarm and stack $STACK an interrupted smoke run left behind"
  remove_swarm
  SWARM_PASSED=""
  swarm_state="$(docker info -f '{{.Swarm.LocalNodeState}}')"
fi
if [ "${SMOKE_SWARM:-1}" = 0 ]; then
  say "swarm part skipped (SMOKE_SWARM=0)"
elif [ "$swarm_state" != inactive ]; then
  say "swarm part skipped: this engine is already in a swarm (state $swarm_state); the test does not deploy on a real swarm"
else
  step "single-node swarm: docker swarm init, label racer.trainer=true, docker/stack-deploy.sh $STACK"
  docker swarm init --advertise-addr 127.0.0.1 >"$WORK/swarm-init.log" 2>&1 || { cat "$WORK/swarm-init.log" >&2; fail "docker swarm init failed"; }
  STARTED_SWARM=1
  docker node update --label-add racer.trainer=true "$(docker info -f '{{.Swarm.NodeID}}')" >/dev/null
  sed -e "s/^RACER_MODEL_PREFIX=.*/RACER_MODEL_PREFIX=$PREFIX-swarm/" -e '/^MINIO_PUBLISH_ADDRESS=/d' \
    -e '/^MINIO_API_PORT=/d' -e '/^MINIO_CONSOLE_PORT=/d' "$WORK/smoke.env" >"$WORK/swarm.env"
  ENV_FILE="$WORK/swarm.env" docker/stack-deploy.sh "$STACK" >"$WORK/stack-deploy.log" 2>&1 \
    || { cat "$WORK/stack-deploy.log" >&2; fail "docker/stack-deploy.sh failed"; }
  services="$(docker stack services "$STACK" --format '{{.Name}}' | sort | tr '\n' ' ')"
  [ "$services" = "${STACK}_minio ${STACK}_minio-setup ${STACK}_redis ${STACK}_rollout-0 ${STACK}_rollout-1 ${STACK}_trainer " ] \
    || fail "the stack has services '$services', expected minio, minio-setup, redis, rollout-0, rollout-1, trainer"
  for service in trainer rollout-0 rollout-1; do
    expected="$WORKER_IMAGE"; [ "$service" = trainer ] && expected="$TRAINER_IMAGE"
    actual="$(docker service inspect -f '{{.Spec.TaskTemplate.ContainerSpec.Image}}' "${STACK}_$service")"
    [ "${actual%%@*}" = "$expected" ] || fail "swarm service $service runs image $actual, expected $expected"
  done
  done_step "services: $services (trainer on $TRAINER_IMAGE, the others on $WORKER_IMAGE)"

  step "waiting for the swarm trainer to finish (at most $TRAIN_TIMEOUT_S s)"
  deadline=$((SECONDS + TRAIN_TIMEOUT_S))
  trainer_id=""
  while [ -z "$trainer_id" ]; do  # the task's container appears once the image is scheduled
    trainer_id="$(docker ps -aq --filter "label=com.docker.swarm.service.name=${STACK}_trainer" | tail -1)"
    [ -n "$trainer_id" ] || { [ $SECONDS -lt $deadline ] || fail "the swarm trainer task never started"; sleep 1; }
  done
  trainer_exit="$(timeout $((deadline - SECONDS)) docker wait "$trainer_id" || echo timeout)"
  docker service logs --raw "${STACK}_trainer" >"$WORK/swarm-trainer.log" 2>&1 || true
  [ "$trainer_exit" != timeout ] || fail "the swarm trainer did not finish within $TRAIN_TIMEOUT_S s (log: $WORK/swarm-trainer.log)"
  [ "$trainer_exit" = 0 ] || fail "the swarm trainer exited with status $trainer_exit (log: $WORK/swarm-trainer.log)"
  done_step
  step "checking the swarm run's trainer log and store"
  check_trainer_log "$WORK/swarm-trainer.log"
  check_store "${STACK}_default" "$WORK/swarm.env"
  done_step
  step "removing the stack and leaving the swarm"
  remove_swarm
  done_step
fi

say "PASSED in $((SECONDS - T0)) s (compose part: ${COMPOSE_SECONDS} s): docker compose trained 2 iterations with workers in worlds base and carpet; checkpoints, pointer and simtraces are in MinIO; evaluation, analysis and a race ran; the viewer served its page${SWARM_PASSED:+; the same on a single-node swarm with docker stack deploy}"
