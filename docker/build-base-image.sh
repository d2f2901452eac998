#!/usr/bin/env bash
# Builds a local Debian bookworm base image with Python 3.11 for machines that reach no container
# registry (no Docker Hub): `debootstrap` + `docker import`. The racer Dockerfiles take the base
# image as a build argument (BASE_IMAGE); on a normal machine they default to the official
# python:3.11-slim-bookworm and this script is not needed.
#
#   docker/build-base-image.sh [IMAGE]          # default IMAGE: racer-base:bookworm
#
# Environment:
#   DEBIAN_MIRROR   Debian mirror for debootstrap and the image's apt sources (default http://deb.debian.org/debian)
#   HOST_CA_BUNDLE  CA bundle to install as the image's /etc/ssl/certs/ca-certificates.crt, so that pip inside
#                   builds trusts the same certificates as this host (default /etc/ssl/certs/ca-certificates.crt;
#                   set it to an empty string to keep Debian's own bundle); also kept unchanged as
#                   /etc/ssl/certs/host-ca-bundle.crt (pass that as PIP_CERT), and the host's local CAs
#                   (/usr/local/share/ca-certificates/*.crt) survive later update-ca-certificates runs.
#                   CA certificates are public, no secret.
#   FORCE=1         rebuild even when the image exists.
#
# The image is small (about 150 MB): minbase + python3 (3.11.2), python3-venv, ca-certificates, bash.
set -euo pipefail

IMAGE="${1:-racer-base:bookworm}"
MIRROR="${DEBIAN_MIRROR:-http://deb.debian.org/debian}"
CA_BUNDLE="${HOST_CA_BUNDLE-/etc/ssl/certs/ca-certificates.crt}"

say() { printf '[base-image] %s\n' "$*"; }
die() { printf '[base-image] ERROR: %s\n' "$*" >&2; exit 1; }

if [ "${FORCE:-0}" != 1 ] && docker image inspect "$IMAGE" >/dev/null 2>&1; then
  say "$IMAGE exists (FORCE=1 rebuilds it)"
  exit 0
fi
[ "$(id -u)" -eq 0 ] || die "debootstrap needs root"
if ! command -v debootstrap >/dev/null 2>&1; then
  say "installing debootstrap"
  apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq debootstrap >/dev/null
fi

rootfs="$(mktemp -d /var/tmp/racer-base.XXXXXX)"
trap 'rm -rf "$rootfs"' EXIT
say "debootstrap bookworm from $MIRROR into $rootfs (1-3 minutes)"
debootstrap --variant=minbase --include=python3,python3-venv,ca-certificates \
  bookworm "$rootfs" "$MIRROR" >"$rootfs.log" 2>&1 || { tail -30 "$rootfs.log" >&2; rm -f "$rootfs.log"; die "debootstrap failed"; }
rm -f "$rootfs.log"

# Same apt sources as a Debian bookworm image: main, updates, security.
security="${MIRROR%/debian}/debian-security"
cat >"$rootfs/etc/apt/sources.list" <<EOF
deb $MIRROR bookworm main
deb $MIRROR bookworm-updates main
deb $security bookworm-security main
EOF
# Container-friendly apt: no recommends, no docs, keep the image lean.
cat >"$rootfs/etc/apt/apt.conf.d/90racer" <<'EOF'
APT::Install-Recommends "false";
APT::Install-Suggests "false";
EOF
if [ -n "$CA_BUNDLE" ]; then
  [ -r "$CA_BUNDLE" ] || die "HOST_CA_BUNDLE $CA_BUNDLE is not readable"
  # The host's local CAs go where update-ca-certificates keeps them, so that a package install inside
  # a build (which regenerates the bundle) keeps trusting them; the whole bundle is also copied as is.
  if compgen -G "/usr/local/share/ca-certificates/*.crt" >/dev/null; then
    cp /usr/local/share/ca-certificates/*.crt "$rootfs/usr/local/share/ca-certificates/"
  fi
  cp "$CA_BUNDLE" "$rootfs/etc/ssl/certs/ca-certificates.crt"
  cp "$CA_BUNDLE" "$rootfs/etc/ssl/certs/host-ca-bundle.crt"
fi
# Trim: apt lists and caches are re-fetched by the builds.
rm -rf "$rootfs"/var/lib/apt/lists/* "$rootfs"/var/cache/apt/archives/*.deb "$rootfs"/usr/share/doc/* "$rootfs"/usr/share/man/*

say "importing as $IMAGE"
tar -C "$rootfs" --numeric-owner -c . | docker import \
  -c 'ENV LANG=C.UTF-8 PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin' \
  -c 'CMD ["/bin/bash"]' \
  -m "racer local base: debootstrap bookworm + python3.11" - "$IMAGE" >/dev/null
docker run --rm "$IMAGE" python3 -c 'import sys, venv; print("[base-image] python", sys.version.split()[0])'
say "done: $(docker image inspect -f '{{.Size}}' "$IMAGE" | awk '{printf "%.0f MB", $1/1e6}')"
