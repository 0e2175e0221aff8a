"""Where the benchmarks find the shared third-party data: `../shared/data` beside the checkout
(as in CI), or the folder REAL2CODE_SHARED_DATA names (as the tests read it, tests/conftest.py)."""

from __future__ import annotations

import os
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
SHARED_DATA = Path(os.environ.get("REAL2CODE_SHARED_DATA", REPO.parent / "shared" / "data"))
