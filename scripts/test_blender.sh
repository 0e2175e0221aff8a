#!/usr/bin/env bash
# Set up (if needed) and run the Blender add-on's tests, headless, in the add-on's own venv.
# They build and validate the extension zip, install it with Blender's extension installer,
# and use the main venv (scripts/setup.sh) for inputs, references and the full check.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
scripts/setup_blender.sh
exec .venv-blender/bin/python -m pytest -q blender_addon/tests "$@"
