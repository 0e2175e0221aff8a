"""The learned joint predictor: inference with the shipped weights (the network is
:mod:`.network`, its training :mod:`.train`, its metrics :mod:`.evaluate`).

Per box it predicts whether it is the root, and for the others the joint type, the box axis
(``idx``), the edge, the sign and the parent box (a pointer over the other boxes) — the
classification Real2Code asks of its fine-tuned CodeLlama, from a model of ~0.2 M
parameters that trains on these CPUs (``python -m pipeline.predictors.train``) and
ships its weights with the package.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..joint_code import ArticulationProgram, ChildJoint, _check_tree
from ..obb import OBB
from .features import EDGES, box_features
from .network import JOINT_TYPES, build_network

WEIGHTS = Path(__file__).resolve().parent / "weights" / "joint_predictor.pt"


@dataclass
class LearnedPredictor:
    network: object
    config: dict = field(default_factory=dict)
    name: str = "learned"

    @classmethod
    def load(cls, path: str | Path | None = None) -> LearnedPredictor:
        from ..weights import load_network

        net, config = load_network(path or WEIGHTS, "joint-predictor",
                                   lambda c: build_network(**c),
                                   "python -m pipeline.predictors.train")
        return cls(net, config)

    def predict(self, boxes: list[OBB]) -> ArticulationProgram:
        import torch

        feats = torch.from_numpy(box_features(boxes))[None]
        pad = torch.zeros(1, len(boxes), dtype=torch.bool)
        with torch.no_grad():
            out = {k: v[0].numpy() for k, v in self.network(feats, pad).items()}
        return decode(out, len(boxes), boxes)


ALIGNED_COS = np.cos(np.radians(3.0))


def hinge_axis_candidates(child: OBB, parent: OBB) -> list[int]:
    """A turn about a hinge keeps the hinge axis parallel to a parent axis and tilts the
    other two: when the child is turned, only its axes still aligned with the parent can be
    the hinge. When nothing is turned (a closed door) every axis remains possible."""
    aligned = [i for i in range(3) if np.abs(parent.R.T @ child.R[:, i]).max() > ALIGNED_COS]
    return aligned if len(aligned) == 1 else [0, 1, 2]


TURNED_DEG = 10.0  # a child box turned this far about a parent axis has turned: no slide


def turned(child: OBB, parent: OBB) -> bool:
    """Whether the child's box is turned about one axis it shares with its parent by at
    least :data:`TURNED_DEG`: a hinge turns its part, a slide only moves it (a drawer's box
    comes out square to its carcass, ``pipeline.obb.aligned_boxes``)."""
    cos = np.abs(parent.R.T @ child.R).max(axis=0)  # each child axis against its nearest
    return (int((cos > ALIGNED_COS).sum()) == 1
            and float(cos.min()) < np.cos(np.radians(TURNED_DEG)))


def slide_axis_candidates(child: OBB, parent: OBB, min_protrusion: float = 0.01) -> list[int]:
    """A drawer pulled out sticks out of its parent along its slide axis: when the child
    protrudes (by more than ``min_protrusion`` m) past one face of its parent, only the child
    axis along that face's normal can be the slide. Otherwise every axis remains possible."""
    rel = parent.R.T @ (child.center - parent.center)
    reach = np.abs(parent.R.T @ child.R) @ child.extent
    protrusion = np.abs(rel) + reach - parent.extent
    k = int(np.argmax(protrusion))
    if protrusion[k] < min_protrusion or np.sort(protrusion)[-2] > 0.5 * protrusion[k]:
        return [0, 1, 2]
    return [int(np.argmax(np.abs(child.R.T @ parent.R[:, k])))]


def decode(out: dict[str, np.ndarray], n: int, boxes: list[OBB] | None = None
           ) -> ArticulationProgram:
    """The most likely valid program from the network's scores: the root first, then each
    child's joint, then parents chosen so that the joints form a tree. With ``boxes``, the
    type and axis are restricted to what the geometry allows (a box turned from its parent's
    is a hinge's; a hinge's axis is one a turn leaves aligned; a slide's the axis it sticks
    out along); the network scores the rest."""
    root = int(np.argmax(out["root"][:n]))
    joints = []
    parent_scores = out["parent"][:n, :n].copy()
    for i in range(n):
        if i == root:
            continue
        idx_scores = out["idx"][i].copy()
        jtype = JOINT_TYPES[int(np.argmax(out["type"][i]))]
        if boxes is not None:
            parent = int(np.argmax(np.where(np.arange(n) == i, -np.inf, parent_scores[i])))
            if turned(boxes[i], boxes[parent]):
                jtype = "hinge"
            candidates = hinge_axis_candidates if jtype == "hinge" else slide_axis_candidates
            allowed = candidates(boxes[i], boxes[parent])
            idx_scores[[k for k in range(3) if k not in allowed]] = -np.inf
        idx = int(np.argmax(idx_scores))
        edge = EDGES[int(np.argmax(out["edge"][i, idx]))]
        sign = (-1, 1)[int(np.argmax(out["sign"][i, idx]))]
        joints.append(ChildJoint(i, jtype, idx, edge if jtype == "hinge" else (0, 0), sign))
    parents = _tree_parents(parent_scores, root, [j.box for j in joints])
    joints = [ChildJoint(j.box, j.type, j.idx, j.edge, j.sign,
                         None if parents[j.box] == root else parents[j.box]) for j in joints]
    program = ArticulationProgram(root, tuple(joints))
    _check_tree(program, None)
    return program


def _tree_parents(scores: np.ndarray, root: int, children: list[int]) -> dict[int, int]:
    """Greedy attachment: repeatedly attach the (child, attached box) pair with the highest
    score, which always yields a tree rooted at ``root``."""
    attached = {root}
    parents: dict[int, int] = {}
    remaining = set(children)
    while remaining:
        best = max(((c, p) for c in remaining for p in attached), key=lambda cp: scores[cp])
        parents[best[0]] = best[1]
        attached.add(best[0])
        remaining.discard(best[0])
    return parents
