#!/usr/bin/env bash
# Set up .venv-engines: the physics engines whose pins clash with the main venv, run by
# `real2code simulate` as subprocesses (real2code_export/dynamics/venv.py): PhysX through
# ovphysx 0.7 (+ its schemas) and Newton 1.8 with its importers (usd-core < 26.9, its own
# warp) and its MuJoCo solver (mujoco 3.17, mujoco-warp), and SAPIEN 3.0 (its PhysX on the
# CPU; 0.4 GB, 35 s of the install). About 3.5 minutes and 3.3 GB on a fresh machine
# (measured here: 2 min 48 s before SAPIEN; open3d, which newton's importers pull, is 0.9 GB).
# Idempotent: reruns skip what is in place (stamp = hash of this script).
set -euo pipefail
cd "$(dirname "$0")/.."

PY=${PYTHON_ENGINES:-python3.11}
[ -x .venv-engines/bin/python ] || "$PY" -m venv .venv-engines
stamp=$(sha256sum scripts/setup_engines.sh | cut -c1-16)
if [ "$(cat .venv-engines/.real2code-stamp 2>/dev/null)" != "$stamp" ]; then
  echo "setup: installing ovphysx, newton and sapien into .venv-engines (about 3.5 minutes on a fresh machine)"
  # (this machine's pip config lists local package folders; silence their "ignored" notes)
  .venv-engines/bin/python -m pip install -q --upgrade pip 2> >(grep -v "is ignored" >&2)
  .venv-engines/bin/python -m pip install -q "ovphysx==0.7.0.74035321" \
    "physx-usd-schemas==25.11.2.72696984" "newton[importers]==1.8.0" "mujoco~=3.17.0" \
    "mujoco-warp~=3.17.0" "sapien==3.0.3" "numpy>=2.0" "lxml>=5.0" \
    2> >(grep -v "is ignored" >&2)
  echo "$stamp" > .venv-engines/.real2code-stamp
fi
