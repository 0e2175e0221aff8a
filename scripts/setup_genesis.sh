#!/usr/bin/env bash
# Set up .venv-genesis: Genesis 1.4.5 for `real2code simulate --engines genesis-urdf,genesis-mjcf`
# (real2code_export/dynamics/genesis.py), run as a subprocess. Its own venv: it pins
# mujoco 4.0 (.venv-engines has Newton's 3.17) and needs torch. torch==2.13.0 is asked for by
# its exact version so that pip takes this machine kind's CPU wheel (/opt/wheels) where there
# is one; elsewhere PyPI's build, with its CUDA packages (several GB more).
# About 2 min 40 s and 4.0 GB on a fresh machine (measured here). Idempotent (stamp = hash of
# this script). REAL2CODE_SKIP_GENESIS=1 skips it.
set -euo pipefail
cd "$(dirname "$0")/.."
[ "${REAL2CODE_SKIP_GENESIS:-0}" = "1" ] && exit 0

PY=${PYTHON_ENGINES:-python3.11}
[ -x .venv-genesis/bin/python ] || "$PY" -m venv .venv-genesis
stamp=$(sha256sum scripts/setup_genesis.sh | cut -c1-16)
if [ "$(cat .venv-genesis/.real2code-stamp 2>/dev/null)" != "$stamp" ]; then
  echo "setup: installing genesis-world and torch (CPU) into .venv-genesis (about 3 minutes on a fresh machine)"
  # (this machine's pip config lists local package folders; silence their "ignored" notes)
  .venv-genesis/bin/python -m pip install -q --upgrade pip 2> >(grep -v "is ignored" >&2)
  .venv-genesis/bin/python -m pip install -q "torch==2.13.0" "genesis-world==1.4.5" \
    "numpy>=2.0" "lxml>=5.0" 2> >(grep -v "is ignored" >&2)
  echo "$stamp" > .venv-genesis/.real2code-stamp
fi
