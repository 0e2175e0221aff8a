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


# -- public robot corpora (the `corpus` tests) ----------------------------------------------------
def example_robot_data_dir() -> Path | None:
    """The URDF corpus the PyPI package example-robot-data installs (None when absent)."""
    import sysconfig

    path = Path(sysconfig.get_paths()["purelib"]) / "cmeel.prefix/share/example-robot-data/robots"
    return path if path.is_dir() else None


def pybullet_data_dir() -> Path | None:
    """The robot files the PyPI package pybullet ships (``pybullet_data``; None when absent)."""
    try:
        import pybullet_data
    except ImportError:
        return None
    return Path(pybullet_data.getDataPath())


def pybullet_sources(root: Path) -> list[Path]:
    """pybullet_data's URDFs and MJCF files, less its 1000 generated ``random_urdfs`` (one
    link and one OBJ each, all alike)."""
    urdf = [p for p in sorted(root.rglob("*.urdf")) if "random_urdfs" not in p.parts]
    return urdf + sorted((root / "mjcf").glob("*.xml"))


def corpus_sources() -> list[tuple[str, Path]]:
    """(id, file) of every URDF of example-robot-data, every main model of the MuJoCo
    Menagerie snapshot in ../shared/data and the robot files of pybullet_data (other people's
    URDF and MJCF, from another toolchain); a placeholder id when a corpus is absent (its
    test then skips with a message)."""
    out: list[tuple[str, Path]] = []
    erd = example_robot_data_dir()
    if erd is None:
        out.append(("erd-absent", Path("example-robot-data (pip install example-robot-data)")))
    else:
        out += [(f"erd/{p.relative_to(erd)}", p) for p in sorted(erd.rglob("*.urdf"))]
    bullet = pybullet_data_dir()
    if bullet is None:
        out.append(("pybullet-absent", Path("pybullet_data (pip install pybullet)")))
    else:
        out += [(f"pybullet/{p.relative_to(bullet)}", p) for p in pybullet_sources(bullet)]
    menagerie = SHARED_DATA / "mujoco_menagerie"
    if not (menagerie / "index.json").is_file():
        out.append(("menagerie-absent", menagerie))
    else:
        out += [(f"menagerie/{e['model']}", menagerie / e["model"])
                for e in json.loads((menagerie / "index.json").read_text())]
    return out
