#!/usr/bin/env bash
# Set up a fresh machine for real2code_export: system libraries, the main venv (.venv,
# numpy 2), the glTF validator (npm). Idempotent: reruns skip what is already in place.
set -euo pipefail
cd "$(dirname "$0")/.."

# System libraries: open3d needs libusb-1.0-0, offscreen MuJoCo rendering needs libosmesa6,
# the web viewer's headless screenshots need Debian's chromium.
need=()
for pkg in libusb-1.0-0 libosmesa6 chromium; do
  dpkg -s "$pkg" >/dev/null 2>&1 || need+=("$pkg")
done
command -v node >/dev/null 2>&1 || need+=(nodejs npm)
if [ ${#need[@]} -gt 0 ]; then
  SUDO=""; [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  echo "setup: installing system packages: ${need[*]}"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq "${need[@]}" >/dev/null
fi

# The main venv. Reinstall only when pyproject.toml changed (stamp = its hash).
PY=${PYTHON:-python3}
[ -x .venv/bin/python ] || "$PY" -m venv .venv
stamp=$(sha256sum pyproject.toml | cut -c1-16)
if [ "$(cat .venv/.real2code-stamp 2>/dev/null)" != "$stamp" ]; then
  echo "setup: installing the Python packages into .venv (about 2 minutes on a fresh machine)"
  # (this machine's pip config lists local package folders; silence their "ignored" notes)
  .venv/bin/python -m pip install -q --upgrade pip 2> >(grep -v "is ignored" >&2)
  .venv/bin/python -m pip install -q -e ".[all]" 2> >(grep -v "is ignored\|BuildBackendWarning\|^ " >&2)
  echo "$stamp" > .venv/.real2code-stamp
fi

# The Khronos glTF validator (npm package gltf-validator), pinned by its package-lock.
validator=real2code_export/formats/gltf_validator
if [ -f "$validator/package.json" ] && [ ! -d "$validator/node_modules/gltf-validator" ]; then
  echo "setup: installing the Khronos glTF validator (npm)"
  (cd "$validator" && npm ci --silent --no-audit --no-fund)
fi

# The web viewer's three.js (npm package three), pinned by its package-lock.
viewer=real2code_export/viewer/web
if [ ! -f "$viewer/node_modules/three/build/three.module.js" ]; then
  echo "setup: installing the web viewer's three.js (npm)"
  (cd "$viewer" && npm ci --silent --no-audit --no-fund)
fi

# The engines that need their own venv (PhysX via ovphysx, Newton, SAPIEN): see
# setup_engines.sh; Genesis (torch, mujoco 4.0): see setup_genesis.sh.
scripts/setup_engines.sh
scripts/setup_genesis.sh
