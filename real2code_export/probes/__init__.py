"""Kinematic probes: a file loaded in its own tool, posed by joint name, asked for the world
pose of every part. ``real2code check`` compares probes; it never asks our own writer.

Each probe module offers ``open_probes(path) -> list[Probe]`` (a URDF yields two: MuJoCo and
Pinocchio). Modules are imported only when a file of their kind is checked.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

import numpy as np

from ..errors import CheckError


@dataclass(frozen=True)
class JointInfo:
    """A movable joint as the tool sees it: name, kind and range (None: unbounded)."""

    name: str
    kind: str  # "revolute", "prismatic" or "continuous"
    lower: float | None
    upper: float | None


class Probe(Protocol):
    label: str  # e.g. "MuJoCo (MJCF)"
    path: Path
    joints: list[JointInfo]  # the movable joints the tool found
    parts: list[str]  # the part (body/link/prim/node) names the tool found

    def poses(self, q: dict[str, float]) -> dict[str, np.ndarray]:
        """World pose (4x4) of every part at joint values ``q`` (by joint name; joints not
        named are at 0)."""
        ...

    # Optional, used by check when present (one call instead of one per configuration):
    # pose_array(values: (N, len(joints)) array in the order of ``joints``)
    #   -> (N, len(parts), 4, 4) world poses in the order of ``parts``.


# extension -> modules whose open_probes() handle it, in report order
PROBE_MODULES: dict[str, tuple[str, ...]] = {
    ".json": ("real2code_export.probes.model",),
    ".xml": ("real2code_export.probes.mujoco",),
    ".mjcf": ("real2code_export.probes.mujoco",),
    ".urdf": ("real2code_export.probes.mujoco", "real2code_export.probes.pinocchio"),
    ".usda": ("real2code_export.probes.usd",),
    ".usd": ("real2code_export.probes.usd",),
    ".usdc": ("real2code_export.probes.usd",),
    ".glb": ("real2code_export.probes.gltf",),
    ".gltf": ("real2code_export.probes.gltf",),
}


def open_probes(path: str | Path) -> list[Probe]:
    """Every probe for ``path`` (chosen by extension)."""
    path = Path(path)
    if not path.exists():
        raise CheckError(f"{path}: no such file")
    modules = PROBE_MODULES.get(path.suffix.lower())
    if modules is None:
        raise CheckError(f"{path}: cannot check files of type {path.suffix!r} "
                         f"(known: {', '.join(sorted(PROBE_MODULES))})")
    probes: list[Probe] = []
    for name in modules:
        probes.extend(importlib.import_module(name).open_probes(path))
    return probes
