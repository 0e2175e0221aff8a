#!/usr/bin/env bash
# The converters users pick instead of real2code, for bench/corpora.py, in their own venv
# (.venv-converters, or the folder REAL2CODE_CONVERTERS names): they pin other mujoco /
# usd-core versions than ours. Idempotent.
set -euo pipefail
cd "$(dirname "$0")/.."
VENV=${REAL2CODE_CONVERTERS:-.venv-converters}
PY=${PYTHON:-python3.11}
if [ ! -x "$VENV/bin/urdf_usd_converter" ] || [ ! -x "$VENV/bin/mujoco_usd_converter" ]; then
    "$PY" -m venv "$VENV"
    "$VENV/bin/pip" install -q "urdf-usd-converter==0.3.4" "mujoco-usd-converter==0.8.0"
fi
"$VENV/bin/urdf_usd_converter" --help >/dev/null
"$VENV/bin/mujoco_usd_converter" --help >/dev/null
echo "converters ready in $VENV"
