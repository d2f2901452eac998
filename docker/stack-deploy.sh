#!/usr/bin/env bash
# Deploys docker-compose.yml on a Docker swarm: `docker stack deploy` with the same file and .env.
#
#   docker/stack-deploy.sh [STACK]        # default stack name: racer
#
# Run it on a manager node, in the repository (the trainer's node: redis.conf and the custom files
# folder are bind-mounted from here). Before the first deploy:
#   docker swarm init                                             # or join nodes to an existing swarm
#   docker node update --label-add racer.trainer=true <this node>  # trainer, Redis and MinIO run there
# and make the images available where they run (a registry, or `docker save IMAGE | ssh NODE docker load`):
# RACER_WORKER_IMAGE (no torch, ~1.5 GB) on every node, RACER_TRAINER_IMAGE (with torch, ~7 GB) and the
# Redis/MinIO images on the trainer's node only. Rollout workers run on any node.
#
# The file goes through `docker compose config` (interpolates .env, resolves paths) and
# docker/bin/racer-stack-filter (drops what the swarm loader rejects: long-form depends_on, build,
# profiles; the filter runs in the worker image, so no host Python is needed).
# Environment: ENV_FILE (default .env), COMPOSE_FILES (default docker-compose.yml).
set -euo pipefail
cd "$(dirname "$0")/.."
STACK="${1:-racer}"
ENV_FILE="${ENV_FILE:-.env}"
[ -f "$ENV_FILE" ] || { echo "stack-deploy: $ENV_FILE not found (cp .env.example .env)" >&2; exit 1; }
if docker compose version >/dev/null 2>&1; then compose=(docker compose); else compose=(docker-compose); fi
setting() { grep -E "^$1=" "$ENV_FILE" | tail -1 | cut -d= -f2-; }
image="$(setting RACER_WORKER_IMAGE)"
image="${image:-racer-worker:latest}"
trainer_image="$(setting RACER_TRAINER_IMAGE)"
trainer_image="${trainer_image:-racer-trainer:latest}"
workers="$(setting RACER_WORKERS)"
workers="${workers:-4}"
for needed in "$image" "$trainer_image"; do
  docker image inspect "$needed" >/dev/null 2>&1 || { echo "stack-deploy: image $needed not found: docker compose build first" >&2; exit 1; }
done

args=()
for file in ${COMPOSE_FILES:-docker-compose.yml}; do args+=(-f "$file"); done
"${compose[@]}" --env-file "$ENV_FILE" "${args[@]}" config \
  | docker run --rm -i --entrypoint racer-stack-filter "$image" --workers "$workers" \
  | docker stack deploy --compose-file - "$STACK"
echo "stack-deploy: deployed stack $STACK; watch it with: docker stack ps $STACK; docker service logs -f ${STACK}_trainer"
