"""Shared test helpers: where the third-party data lives, and skipping cleanly without it."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
# ../shared beside the checkout (as in CI), or a path given by REAL2CODE_SHARED_DATA.
SHARED_DATA = Path(os.environ.get("REAL2CODE_SHARED_DATA", REPO.parent / "shared" / "data"))


def partnet_dir() -> Path:
    """The PartNet-Mobility test objects; skips the calling test when they are absent."""
    path = SHARED_DATA / "partnet_mobility"
    if not (path / "index.json").is_file():
        pytest.skip(f"PartNet-Mobility data not found at {path} (set REAL2CODE_SHARED_DATA)")
    return path


def partnet_objects(split: str | None = None) -> list[Path]:
    """Folders of the PartNet-Mobility objects (all, or one split: 'dev' / 'holdout')."""
    root = partnet_dir()
    index = json.loads((root / "index.json").read_text())
    return [root / e["id"] for e in index if split is None or e["split"] == split]


def partnet_ids() -> list[str]:
    """Object ids for parametrising tests (empty when the data is absent: tests then skip)."""
    index = SHARED_DATA / "partnet_mobility" / "index.json"
    if not index.is_file():
        return ["absent"]
    return [e["id"] for e in json.loads(index.read_text())]


def measured_dir() -> Path:
    path = SHARED_DATA / "measured"
    if not path.is_dir():
        pytest.skip(f"measured trajectories not found at {path} (set REAL2CODE_SHARED_DATA)")
    return path
