#!/usr/bin/env bash
# Installs everything racer needs on a Debian bookworm machine, idempotently:
#   Debian packages (python3.11 with venv, redis-server, Mesa EGL/OSMesa for headless MuJoCo, ffmpeg, and
#   chromium + chromium-driver for the viewer's browser tests),
#   a MinIO server (built with `go install` when no `minio` is on PATH; ~3 minutes the first time),
#   and the Python dependencies in ./.venv. A second run only checks and exits in seconds.
set -euo pipefail
cd "$(dirname "$0")/.."

MINIO_MODULE="github.com/minio/minio@v0.0.0-20260212201848-7aac2a2c5b7c"
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

if ! command -v minio >/dev/null 2>&1 && [ ! -x "$HOME/go/bin/minio" ]; then
  command -v go >/dev/null 2>&1 || { echo "[setup] Go is needed to build MinIO (go install $MINIO_MODULE)" >&2; exit 1; }
  say "building MinIO with go install (about 3 minutes, once)"
  (cd /tmp && go install "$MINIO_MODULE")
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
minio_bin="$(command -v minio 2>/dev/null || echo "$HOME/go/bin/minio")"
ln -sf "$minio_bin" .venv/bin/minio
say "ready: $(.venv/bin/python --version), redis-server $(redis-server --version | sed 's/.*v=\([^ ]*\).*/\1/'), minio at $minio_bin"
