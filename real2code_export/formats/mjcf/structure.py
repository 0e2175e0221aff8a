"""Which parts the MJCF writer folds into something else than a body of their own.

- A frame (no mass, no geometry) fixed to its parent with nothing hanging from it is a
  ``<site>`` of the parent's body: an MJCF site read back, a URDF frame-only link.
- The massless intermediate parts the MJCF reader makes for a body with several joints
  (named ``<body>_<joint>``, see :mod:`.read`) are merged back: the body gets its joints
  again, in order, each at its anchor, so MJCF -> model -> MJCF keeps the body tree.
"""

from __future__ import annotations

import numpy as np

from ...model import ArticulatedObject, Joint, JointType, Part
from ...repairs import NEGLIGIBLE_MASS


def site_parts(obj: ArticulatedObject) -> set[str]:
    """The parts written as sites: the object's frames (:meth:`ArticulatedObject.frame_parts`)."""
    return obj.frame_parts()


def body_chains(obj: ArticulatedObject) -> dict[str, list[Joint]]:
    """First joint's name -> the joints of one MJCF body (two or more), for each chain of
    intermediate parts to merge. A part is merged when it has no geometry and at most the
    negligible mass the reader's repair gives it, one joint in and one out (hinge, slide or
    ball; the one out only translates, as the reader makes it, and stands at 0), and is
    named ``<last part>_<joint in>``. (A later joint away from 0 would be written as its
    ``ref``, which the reader takes back as a turned origin: such a chain stays bodies.)"""
    tree = obj.tree()
    final_of: dict[str, str | None] = {}  # part -> the chain's last part (None: not merged)

    def final(name: str) -> str | None:
        if name not in final_of:
            final_of[name] = None
            out = tree.children[name]
            into = tree.parent.get(name)
            if (into is not None and len(out) == 1 and _in_body(into) and _in_body(out[0])
                    and _placeholder(tree.parts[name]) and out[0].state == 0.0
                    and np.allclose(out[0].origin[:3, :3], np.eye(3), rtol=0, atol=1e-12)):
                last = final(out[0].child) or out[0].child
                if name == f"{last}_{into.name}":
                    final_of[name] = last
        return final_of[name]

    chains = {}
    for j in obj.joints:
        if final(j.child) is not None and final(j.parent) is None:
            chain = [j]
            while final(chain[-1].child) is not None:
                chain.append(tree.children[chain[-1].child][0])
            chains[j.name] = chain
    return chains


def _in_body(joint: Joint) -> bool:
    return joint.type not in (JointType.FIXED, JointType.FLOATING)


def _placeholder(part: Part) -> bool:
    if part.visual is not None or part.collision or part.texture is not None:
        return False
    i = part.inertial
    return i is None or (i.mass <= NEGLIGIBLE_MASS and not np.any(i.com))


def anchors(chain: list[Joint]) -> tuple[np.ndarray, list[np.ndarray]]:
    """The body's pose in its parent and each joint's anchor in the body, for a chain of
    joints merged into one body; the last anchor is the body origin (the last part's frame)."""
    points = [np.zeros(3)]
    for joint in reversed(chain[1:]):
        points.insert(0, points[0] - joint.origin[:3, 3])
    base = chain[0].origin.copy()
    base[:3, 3] = base[:3, 3] - base[:3, :3] @ points[0]
    return base, points
