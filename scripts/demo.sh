#!/usr/bin/env bash
# Set up (if needed) and run the main job: `real2code demo` on the shipped sample.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
exec .venv/bin/real2code demo "$@"
