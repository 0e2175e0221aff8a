#!/usr/bin/env bash
# Set up the Blender add-on's own venv, .venv-blender: Blender as a Python module (bpy 5.0.1,
# which pins numpy < 2 and bundles its own OpenUSD pxr), pytest, and setuptools (to build the
# project's wheel). It is never the main venv: Pinocchio 4 there needs numpy >= 2.
# The add-on's own dependencies are not installed into it: they are the wheels the extension
# bundles (blender_addon/wheels-*.txt, hash-pinned), fetched here into build/blender_addon/wheels
# and loaded by Blender's extension installer in the tests, as in a user's Blender.
# Idempotent: reruns skip what is in place (stamp = hash of this script and the wheel lists).
set -euo pipefail
cd "$(dirname "$0")/.."

PY=${PYTHON_BLENDER:-python3.11}
[ -x .venv-blender/bin/python ] || "$PY" -m venv .venv-blender
stamp=$(cat scripts/setup_blender.sh blender_addon/wheels-*.txt | sha256sum | cut -c1-16)
if [ "$(cat .venv-blender/.real2code-stamp 2>/dev/null)" != "$stamp" ]; then
  echo "setup: installing bpy 5.0.1, pytest and setuptools into .venv-blender (about a minute on a fresh machine)"
  # (this machine's pip config lists local package folders; silence their "ignored" notes)
  .venv-blender/bin/python -m pip install -q --upgrade pip 2> >(grep -v "is ignored" >&2)
  .venv-blender/bin/python -m pip install -q "bpy==5.0.1" "pytest>=8" "setuptools>=70" \
    2> >(grep -v "is ignored" >&2)
  echo "setup: fetching the wheels the Blender extension bundles"
  .venv-blender/bin/python blender_addon/build.py wheels >/dev/null
  echo "$stamp" > .venv-blender/.real2code-stamp
fi
