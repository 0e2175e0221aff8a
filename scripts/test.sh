#!/usr/bin/env bash
# Set up (if needed) and run the whole test suite: ruff, pytest, then the Blender add-on's
# tests in their own venv (scripts/test_blender.sh). Arguments go to the main pytest run.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
.venv/bin/ruff check .
.venv/bin/python -m pytest -q "$@"
scripts/test_blender.sh
