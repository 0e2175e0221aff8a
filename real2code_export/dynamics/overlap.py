"""How deep the collision pieces of two parts overlap at given joint values, as MuJoCo's
collision detection sees them (each piece is a convex hull, as in every engine).

Every pair of parts counts, parent and child included: a format without contact exclusions
(URDF) leaves those pairs to collide too. The MJCF is loaded with its ``<exclude>`` pairs
removed and parent filtering off; ``mj_forward`` at the joint values gives the contacts,
and a negative distance is an overlap.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class Overlap:
    part_a: str
    part_b: str
    depth: float  # m, the deepest penetration between any two of their pieces


def overlaps(mjcf: Path, q: dict[str, float] | None = None,
             tolerance: float = 1e-4) -> list[Overlap]:
    """Part pairs whose pieces overlap by more than ``tolerance`` (m) at joint values ``q``
    (by joint name; the others at 0), deepest first."""
    import mujoco

    spec = mujoco.MjSpec.from_file(str(mjcf))
    spec.compiler.discardvisual = True
    for exclude in list(spec.excludes):
        spec.delete(exclude)
    model = spec.compile()
    model.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_FILTERPARENT)
    data = mujoco.MjData(model)
    for name, value in (q or {}).items():
        data.qpos[model.joint(name).qposadr[0]] = value
    mujoco.mj_forward(model, data)
    deepest: dict[tuple[str, str], float] = {}
    for c in data.contact[:data.ncon]:
        if c.dist >= -tolerance:
            continue
        a = model.body(model.geom_bodyid[c.geom[0]]).name
        b = model.body(model.geom_bodyid[c.geom[1]]).name
        if a == b:
            continue
        key = tuple(sorted((a, b)))
        deepest[key] = max(deepest.get(key, 0.0), -float(c.dist))
    found = [Overlap(a, b, d) for (a, b), d in deepest.items()]
    return sorted(found, key=lambda o: -o.depth)
