"""Test-time prompting as the paper does it, for any point-promptable mask model: one
consistent 3D part segmentation from per-view masks.

1. Fuse the foreground of every view (pixels with depth) into one cloud.
2. Sample prompt points evenly on it (farthest-point sampling) and project each into every
   view that sees it (in the image and not hidden: its depth agrees with the measured one).
3. Prompt the model there; every mask votes, weighted by its quality (predicted IoU times
   stability), on the cloud points that view sees: each prompt gets a 3D segment.
4. Rank the segments by quality and stability; suppress duplicates by merging each into
   the better part it agrees with where both were observed; give every point the part
   that claims it most; dissolve specks.
5. Every view's label image: each pixel takes the label of its nearest labelled point.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from ..capture import Capture
from ..fuse import object_diagonal, point_map, project, visible, voxel_downsample


class PromptSegmenter(Protocol):
    name: str

    def set_views(self, frames) -> None:
        """Prepare for prompting on these frames (encode each once)."""

    def predict(self, view: int, prompts_uv: np.ndarray, query_uv: np.ndarray,
                ) -> tuple[np.ndarray, np.ndarray]:
        """Per prompt (capture pixels, u v) the probability that each query pixel lies on
        the prompted part (K, N), and each mask's quality in [0, 1] (K,)."""


@dataclass
class Segmentation:
    """Part labels (1..n_parts) of every view, and of the fused cloud they came from."""

    labels: list[np.ndarray]  # per frame (H, W) uint16, 0 = background
    n_parts: int
    points: np.ndarray  # (N, 3) fused foreground cloud
    point_labels: np.ndarray  # (N,) in 1..n_parts
    method: str
    details: dict = field(default_factory=dict)


@dataclass(frozen=True)
class PromptingOptions:
    prompts: int = 256  # 3D prompt points
    voxel_fraction: float = 1 / 120  # cloud spacing, of the object's diagonal
    nms_iou: float = 0.5  # segments agreeing this much where both were seen are one part
    min_fraction: float = 0.003  # parts with fewer points (of the cloud) are specks
    min_quality: float = 0.3  # a new part needs masks the model itself trusts ...
    min_stability: float = 0.8  # ... and that agree across views


def _farthest_points(points: np.ndarray, n: int) -> np.ndarray:
    """Indices of ``n`` points spread evenly over ``points`` (farthest-point sampling from
    the point nearest the centroid, so the result does not depend on the cloud's order)."""
    n = min(n, len(points))
    chosen = np.empty(n, dtype=int)
    chosen[0] = int(np.argmin(np.linalg.norm(points - points.mean(0), axis=1)))
    dist = np.linalg.norm(points - points[chosen[0]], axis=1)
    for k in range(1, n):
        chosen[k] = int(np.argmax(dist))
        dist = np.minimum(dist, np.linalg.norm(points - points[chosen[k]], axis=1))
    return chosen


def vote(capture: Capture, segmenter: PromptSegmenter, cloud: np.ndarray,
         prompt_index: np.ndarray, tolerance: float) -> tuple[np.ndarray, np.ndarray]:
    """Each prompt's agreement score on every cloud point (M, N; NaN where no view saw
    both) and its mean mask quality (M,)."""
    m, n = len(prompt_index), len(cloud)
    num, den = np.zeros((m, n)), np.zeros((m, n))
    q_sum, q_count = np.zeros(m), np.zeros(m)
    segmenter.set_views(capture.frames)
    for v, frame in enumerate(capture.frames):
        seen, _ = visible(frame, cloud, tolerance)
        prompts = np.nonzero(seen[prompt_index])[0]
        if len(prompts) == 0:
            continue
        query = np.nonzero(seen)[0]
        uv, _ = project(frame, cloud)
        probs, quality = segmenter.predict(v, uv[prompt_index[prompts]], uv[query])
        w = np.clip(quality, 0.05, 1.0)[:, None]
        num[np.ix_(prompts, query)] += w * probs
        den[np.ix_(prompts, query)] += w
        q_sum[prompts] += quality
        q_count[prompts] += 1
    with np.errstate(invalid="ignore", divide="ignore"):
        score = np.where(den > 0, num / den, np.nan)
    return score, np.where(q_count > 0, q_sum / np.maximum(q_count, 1), 0.0)


def _stability(score: np.ndarray) -> np.ndarray:
    """SAM's stability score in 3D: the share of a segment that stays in it when the
    threshold moves from 0.35 to 0.65 (masks that disagree across views score low)."""
    s = np.nan_to_num(score, nan=0.0)
    return (s > 0.65).sum(-1) / np.maximum((s > 0.35).sum(-1), 1)


def group_segments(score: np.ndarray, quality: np.ndarray, prompt_index: np.ndarray,
                   options: PromptingOptions) -> list[list[int]]:
    """Prompts grouped by the part they found, best first (non-maximum suppression that
    merges instead of dropping: a part seen from one side by one prompt and from another
    side by the next is one part).

    Two segments are the same part when they agree where both were observed: their IoU on
    the points that views of both prompts saw is at least ``nms_iou``. Only stable,
    confident segments that hold their own prompt start a new part.
    """
    observed = ~np.isnan(score)
    inside = np.nan_to_num(score, nan=0.0) > 0.5
    stability = _stability(score)
    rank = quality * stability
    own = inside[np.arange(len(prompt_index)), prompt_index]
    groups: list[list[int]] = []
    g_num: list[np.ndarray] = []  # per group: summed scores and observation counts
    g_den: list[np.ndarray] = []
    for p in np.argsort(-rank, kind="stable"):
        if not own[p] or not inside[p].any():
            continue
        best, best_iou = -1, 0.0
        for g in range(len(groups)):
            g_obs = g_den[g] > 0
            g_in = g_obs & (g_num[g] > 0.5 * g_den[g])
            both = observed[p] & g_obs
            union = ((inside[p] | g_in) & both).sum()
            if union == 0:
                continue
            iou = (inside[p] & g_in & both).sum() / union
            if iou > best_iou:
                best, best_iou = g, iou
        if best >= 0 and best_iou >= options.nms_iou:
            groups[best].append(int(p))
            g_num[best] += np.nan_to_num(score[p], nan=0.0)
            g_den[best] += observed[p]
        elif quality[p] >= options.min_quality and stability[p] >= options.min_stability:
            groups.append([int(p)])
            g_num.append(np.nan_to_num(score[p], nan=0.0).copy())
            g_den.append(observed[p].astype(float))
    return groups


def group_scores(score: np.ndarray, groups: list[list[int]]) -> np.ndarray:
    """Each group's mean score on every point (NaN where none of its prompts observed it)."""
    out = np.full((len(groups), score.shape[1]), np.nan)
    for g, members in enumerate(groups):
        s = score[members]
        seen = (~np.isnan(s)).sum(0)
        with np.errstate(invalid="ignore"):
            out[g] = np.where(seen > 0, np.nansum(s, 0) / np.maximum(seen, 1), np.nan)
    return out


def assign(score: np.ndarray, cloud: np.ndarray, min_points: int) -> np.ndarray:
    """Label 1..n of every cloud point from the parts' scores (n, N): the part scoring it
    highest; parts smaller than ``min_points`` dissolve into their neighbours; labels by
    size, largest 1."""
    from scipy.spatial import cKDTree

    if len(score) == 0:
        return np.ones(len(cloud), dtype=int)
    s = np.nan_to_num(score, nan=-1.0)
    active = np.ones(len(score), dtype=bool)
    while True:
        masked = np.where(active[:, None], s, -2.0)
        best = masked.argmax(0)
        claimed = masked.max(0) > 0.5
        sizes = np.bincount(best[claimed], minlength=len(score))
        small = active & (sizes < min_points)
        if not small.any() or small.sum() == active.sum():
            break
        active[np.argmin(np.where(small, sizes, np.inf))] = False  # drop the smallest first
    labels = np.where(claimed, best, -1)
    if (labels < 0).any() and (labels >= 0).any():  # unclaimed points: nearest claimed one
        tree = cKDTree(cloud[labels >= 0])
        _, nn = tree.query(cloud[labels < 0])
        labels[labels < 0] = labels[labels >= 0][nn]
    labels = np.maximum(labels, 0)
    order = np.argsort(-np.bincount(labels, minlength=len(score)), kind="stable")
    remap = np.zeros(len(score), dtype=int)
    present = [k for k in order if (labels == k).any()]
    remap[present] = np.arange(1, len(present) + 1)
    return remap[labels]


def label_views(capture: Capture, cloud: np.ndarray, point_labels: np.ndarray,
                ) -> list[np.ndarray]:
    """Every view's label image from the labelled cloud (nearest labelled point)."""
    from scipy.spatial import cKDTree

    tree = cKDTree(cloud)
    out = []
    for frame in capture.frames:
        pts, valid = point_map(frame)
        lab = np.zeros(frame.depth.shape, dtype=np.uint16)
        if valid.any():
            _, nn = tree.query(pts[valid])
            lab[valid] = point_labels[nn]
        out.append(lab)
    return out


def segment_capture(capture: Capture, segmenter: PromptSegmenter,
                    options: PromptingOptions = PromptingOptions()) -> Segmentation:
    """One consistent part segmentation of every view of ``capture``."""
    diagonal = object_diagonal(capture)
    voxel = diagonal * options.voxel_fraction
    cloud = voxel_downsample(np.concatenate(
        [point_map(f)[0][f.depth > 0] for f in capture.frames]), voxel)
    prompt_index = _farthest_points(cloud, options.prompts)
    score, quality = vote(capture, segmenter, cloud, prompt_index, tolerance=1.5 * voxel)
    groups = group_segments(score, quality, prompt_index, options)
    min_points = max(5, int(options.min_fraction * len(cloud)))
    point_labels = assign(group_scores(score, groups), cloud, min_points)
    n_parts = int(point_labels.max())
    details = {"cloud_points": len(cloud), "prompts": len(prompt_index),
               "prompt_groups": len(groups), "parts": n_parts,
               "prompts_per_group": [len(g) for g in groups]}
    return Segmentation(label_views(capture, cloud, point_labels), n_parts, cloud,
                        point_labels, segmenter.name, details)


def ground_truth_segmentation(capture: Capture) -> Segmentation:
    """The capture's own masks (evaluation; synthetic captures)."""
    if not capture.has_masks:
        from real2code_export.errors import FormatError

        raise FormatError(capture.path, "mask_path", "the capture has no ground-truth masks "
                          "(segmentation 'gt' needs them)")
    diagonal = object_diagonal(capture)
    points, labels = [], []
    for frame in capture.frames:
        pts, valid = point_map(frame)
        points.append(pts[valid])
        labels.append(frame.mask[valid])
    points, labels = np.concatenate(points), np.concatenate(labels).astype(int)
    keep = np.random.default_rng(0).permutation(len(points))[:20000]
    return Segmentation([f.mask.astype(np.uint16) for f in capture.frames],
                        int(labels.max()), points[keep], labels[keep], "gt",
                        {"parts": int(len(np.unique(labels[labels > 0]))),
                         "diagonal": diagonal})
