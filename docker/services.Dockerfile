# Local images for the two infrastructure services, for machines without a container registry.
# docker-compose.yml uses the official images by default (REDIS_IMAGE, MINIO_IMAGE in .env); these
# targets build equivalents from the same base image as the racer image:
#
#   docker build -f docker/services.Dockerfile --target redis --build-arg BASE_IMAGE=racer-base:bookworm -t racer-redis:local EMPTY_DIR
#   docker build -f docker/services.Dockerfile --target minio --build-arg BASE_IMAGE=racer-base:bookworm -t racer-minio:local DIR_WITH_MINIO_BINARY
#
# The MinIO target copies a `minio` server binary from its build context (the context holds only that
# file; scripts/compose-smoke-test.sh uses the one scripts/install-minio.sh builds with
# `go install github.com/minio/minio@...`). No binary is kept in the repository.

ARG BASE_IMAGE=debian:bookworm-slim

# Redis from Debian bookworm (7.0). The official image runs `redis-server CONFIG` the same way, so the
# compose service's command, config mount and healthcheck (redis-cli ping) work with either.
FROM ${BASE_IMAGE} AS redis
RUN apt-get update \
 && DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends redis-server \
 && rm -rf /var/lib/apt/lists/* \
 && mkdir -p /data /usr/local/etc/redis && chown redis:redis /data
USER redis
WORKDIR /data
EXPOSE 6379
CMD ["redis-server", "/usr/local/etc/redis/redis.conf"]

# MinIO server from a binary in the build context. Same command line as the official image
# (`minio server /data --console-address :9001`); the healthcheck in docker-compose.yml needs only bash.
FROM ${BASE_IMAGE} AS minio
# (the binary must be executable in the context: COPY keeps its mode, a chmod here would copy 150 MB again)
COPY minio /usr/local/bin/minio
RUN useradd --system --uid 1001 --home-dir /data minio \
 && mkdir -p /data && chown minio:minio /data \
 && minio --version
USER minio
WORKDIR /data
EXPOSE 9000 9001
ENTRYPOINT ["minio"]
CMD ["server", "/data", "--console-address", ":9001"]
