#!/usr/bin/env bash
# The benchmarks' own venv, .venv-bench: urdf-usd-converter (NVIDIA's URDF -> USD converter),
# the tool bench/export_vs_converter.py compares `real2code export` with. It cannot share the
# main venv: its usd-exchange installs its own OpenUSD `pxr` modules over usd-core's (another
# OpenUSD release), which breaks the project's pxr. Not needed by the tests or CI.
# Idempotent: reruns skip what is in place (stamp = hash of this script).
set -euo pipefail
cd "$(dirname "$0")/.."

PY=${PYTHON_BENCH:-python3.11}
[ -x .venv-bench/bin/python ] || "$PY" -m venv .venv-bench
stamp=$(sha256sum scripts/setup_bench.sh | cut -c1-16)
if [ "$(cat .venv-bench/.real2code-stamp 2>/dev/null)" != "$stamp" ]; then
  echo "setup: installing urdf-usd-converter 0.3.4 into .venv-bench"
  .venv-bench/bin/python -m pip install -q "urdf-usd-converter==0.3.4" \
    2> >(grep -v "is ignored" >&2)
  echo "$stamp" > .venv-bench/.real2code-stamp
fi
