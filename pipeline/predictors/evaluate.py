"""Joint metrics of the paper, by bucket of part count, for any predictor.

For every ground-truth movable joint: whether the predicted joint on the matched child part
has the right type, the angle between the axes (degrees, sign-free), the distance between
the axis lines for revolute joints (correct for parallel lines; in metres and as a
fraction of the object's diagonal), the error of the observed state and of the upper limit.
Parts are matched by what they are made of, not where their centres lie: each predicted
part's surface samples vote for the true part nearest them, and an optimal assignment pairs
parts by how much of each the other holds. A predicted part stands for a true part only if
most of its surface is that part's (:data:`MATCH_SHARE`), so a piece of the carcass read as
a drawer is never credited with the drawer's joint because its centre lies near the
drawer's. Predictions that reorder or rename parts are scored fairly.

Those figures judge each true joint by its matched part only, so a reconstruction that
splits an object into many parts with many joints loses nothing. The stricter score counts
the extras: a predicted movable joint is *correct* when its child is matched to a true part
whose joint has the same type, an axis within :data:`MATCH_AXIS_DEG` and (revolute) an axis
line within :data:`MATCH_POSITION_REL` of the object's diagonal; precision is correct over
predicted movable joints, recall correct over true ones.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import linear_sum_assignment

from real2code_export.model import ArticulatedObject, JointType, forward_kinematics

from ..joint_code import line_distance

BUCKETS = (("2", 2, 2), ("3", 3, 3), ("4-5", 4, 5), ("6-15", 6, 15))
PAPER_GT_BOXES = {  # Real2Code + ground-truth boxes (Table 3): rot deg, pos, type accuracy
    "2": (0.0, 0.07, 0.93), "3": (0.0, 0.04, 1.00), "4-5": (0.0, 0.04, 1.00),
    "6-15": (11.6, 0.03, 0.94)}
PAPER_FULL = {  # Real2Code from RGB-D with its own segmentation (Table 3)
    "2": (7.5, 0.08, 0.80), "3": (0.0, 0.04, 0.89), "4-5": (0.63, 0.07, 0.97),
    "6-15": (30.2, 0.05, 0.89)}


MATCH_AXIS_DEG = 10.0
MATCH_POSITION_REL = 0.1
MATCH_SHARE = 0.5  # of a predicted part's surface that must be its true part's
SURFACE_SAMPLES = 2000  # per part, seeded: the score is deterministic


def bucket_of(n_parts: int) -> str:
    for name, lo, hi in BUCKETS:
        if lo <= n_parts <= hi:
            return name
    return "16+"


@dataclass
class JointScore:
    bucket: str
    revolute: bool  # the truth's kind: state and range errors are in rad, else in m
    type_ok: bool
    axis_deg: float
    position: float | None  # m, revolute only
    position_rel: float | None  # fraction of the object's diagonal
    state_error: float | None
    upper_error: float | None


@dataclass
class JointCount:
    """One object's movable joints: true, predicted and predicted correctly."""

    bucket: str
    true: int
    predicted: int
    correct: int


@dataclass
class Scores:
    joints: list[JointScore] = field(default_factory=list)
    objects: dict[str, int] = field(default_factory=dict)
    counts: list[JointCount] = field(default_factory=list)

    def absorb(self, other: Scores) -> None:
        """Add ``other``'s objects (scored apart, in a worker) after these."""
        self.joints += other.joints
        self.counts += other.counts
        for bucket, n in other.objects.items():
            self.objects[bucket] = self.objects.get(bucket, 0) + n

    def table(self) -> dict[str, dict[str, float]]:
        out = {}
        for name, *_ in BUCKETS:
            js = [j for j in self.joints if j.bucket == name]
            if not js:
                continue
            pos = [j.position for j in js if j.position is not None]
            rel = [j.position_rel for j in js if j.position_rel is not None]

            def mean(values):
                return float(np.mean(values)) if values else float("nan")

            counts = [c for c in self.counts if c.bucket == name]
            correct = sum(c.correct for c in counts)
            predicted = sum(c.predicted for c in counts)
            true = sum(c.true for c in counts)
            out[name] = {
                "objects": self.objects.get(name, 0), "joints": len(js),
                "predicted_joints": predicted,
                "joint_precision": correct / predicted if predicted else float("nan"),
                "joint_recall": correct / true if true else float("nan"),
                "type_accuracy": float(np.mean([j.type_ok for j in js])),
                "axis_error_deg": float(np.mean([j.axis_deg for j in js])),
                "position_error_m": float(np.mean(pos)) if pos else float("nan"),
                "position_error_rel": float(np.mean(rel)) if rel else float("nan"),
                "state_error_rad": mean([j.state_error for j in js
                                         if j.revolute and j.state_error is not None]),
                "state_error_m": mean([j.state_error for j in js
                                       if not j.revolute and j.state_error is not None]),
                "upper_error_rad": mean([j.upper_error for j in js
                                         if j.revolute and j.upper_error is not None]),
                "upper_error_m": mean([j.upper_error for j in js
                                       if not j.revolute and j.upper_error is not None]),
            }
        return out


def _world_axes(obj: ArticulatedObject, base: np.ndarray | None = None):
    poses = forward_kinematics(obj, obj.observed_configuration(), base)
    out = {}
    for j in obj.movable_joints:
        frame = poses[j.parent] @ j.origin
        out[j.child] = (j, frame[:3, :3] @ j.axis, frame[:3, 3])
    return poses, out


def _surfaces(obj: ArticulatedObject, poses) -> dict[str, np.ndarray]:
    """Each part's surface in the world frame, sampled evenly by area (its vertices where it
    has no area)."""
    import trimesh

    out = {}
    for p in obj.parts:
        if p.visual is None or not len(p.visual.vertices):  # nothing to stand for a part
            continue
        mesh = p.visual.transformed(poses[p.name])
        tri = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
        if len(mesh.faces) and tri.area > 0:
            out[p.name] = trimesh.sample.sample_surface(tri, SURFACE_SAMPLES, seed=0)[0]
        else:
            out[p.name] = np.asarray(mesh.vertices, dtype=float)
    return out


def _votes(voters: list[np.ndarray], surfaces: list[np.ndarray]) -> np.ndarray:
    """``votes[j, k]``: the share of ``voters[j]``'s points nearer ``surfaces[k]`` than any
    other surface (one tree over all the surfaces, one query over all the voters)."""
    from scipy.spatial import cKDTree

    owner = np.concatenate([np.full(len(s), k) for k, s in enumerate(surfaces)])
    nearest = owner[cKDTree(np.concatenate(surfaces)).query(np.concatenate(voters))[1]]
    voter = np.concatenate([np.full(len(v), j) for j, v in enumerate(voters)])
    counts = np.zeros((len(voters), len(surfaces)))
    np.add.at(counts, (voter, nearest), 1.0)
    return counts / np.array([len(v) for v in voters])[:, None]


def match_parts(truth: dict[str, np.ndarray],
                predicted: dict[str, np.ndarray]) -> dict[str, str]:
    """True part name -> the predicted part that stands for it, from surface samples (name
    -> points, one world frame). ``share[i, j]``: of predicted part j's samples, the share
    nearer true part i than any other; ``cover[i, j]``: of true part i's, the share nearer
    predicted part j. Pairs are assigned to maximise the summed F-score of the two; a pair
    whose predicted part is not mostly its true part (share below :data:`MATCH_SHARE`) is
    no match."""
    t_names, p_names = list(truth), list(predicted)
    if not t_names or not p_names:
        return {}
    t_surf, p_surf = [truth[n] for n in t_names], [predicted[n] for n in p_names]
    share = _votes(p_surf, t_surf).T
    cover = _votes(t_surf, p_surf)
    f = np.where(share + cover > 0, 2 * share * cover / np.maximum(share + cover, 1e-12), 0.0)
    f[share < MATCH_SHARE] = 0.0
    rows, cols = linear_sum_assignment(-f)
    return {t_names[r]: p_names[c] for r, c in zip(rows, cols, strict=True) if f[r, c] > 0}


def score_object(truth: ArticulatedObject, truth_base: np.ndarray, predicted: ArticulatedObject,
                 scores: Scores) -> dict[str, str]:
    """Add one object's joints to ``scores``. ``truth_base`` places the truth in the world
    frame the prediction was made in; the prediction's root frame is that world frame.
    Returns the match (:func:`match_parts`): each true part's name -> the predicted part's
    it was scored against; a true part no predicted part stands for has its joint scored at
    its worst."""
    bucket = bucket_of(len(truth.parts))
    scores.objects[bucket] = scores.objects.get(bucket, 0) + 1
    t_poses, t_axes = _world_axes(truth, truth_base)
    p_poses, p_axes = _world_axes(predicted)
    match = match_parts(_surfaces(truth, t_poses), _surfaces(predicted, p_poses))
    corners = np.concatenate([p.visual.transformed(t_poses[p.name]).vertices
                              for p in truth.parts if p.visual is not None])
    diagonal = float(np.linalg.norm(corners.max(axis=0) - corners.min(axis=0)))
    correct = 0  # predicted joints on a matched part that agree with its true joint
    for child, (tj, t_axis, t_point) in t_axes.items():
        pred = p_axes.get(match.get(child, ""))
        if pred is None:  # unmatched, or its part has no joint: every error at its worst
            scores.joints.append(JointScore(bucket, tj.type is not JointType.PRISMATIC, False,
                                            90.0, None, None, None, None))
            continue
        pj, p_axis, p_point = pred
        truth_slide = tj.type is JointType.PRISMATIC
        type_ok = truth_slide == (pj.type is JointType.PRISMATIC)
        cos = abs(float(t_axis @ p_axis))
        axis_deg = float(np.degrees(np.arccos(min(1.0, cos))))
        position = rel = None
        if not truth_slide:
            position = line_distance(t_point, t_axis, p_point, p_axis)
            rel = position / diagonal
        state_err = upper_err = None
        if type_ok:
            state_err = abs(tj.state - pj.state)
            if tj.limits is not None and pj.limits is not None:
                upper_err = abs(tj.limits.upper - pj.limits.upper)
        scores.joints.append(JointScore(bucket, not truth_slide, type_ok, axis_deg, position,
                                        rel, state_err, upper_err))
        if type_ok and axis_deg <= MATCH_AXIS_DEG and (rel is None or rel <= MATCH_POSITION_REL):
            correct += 1
    scores.counts.append(JointCount(bucket, len(t_axes), len(p_axes), correct))
    return match
