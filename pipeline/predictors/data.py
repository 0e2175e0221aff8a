"""The joint predictor's training data: procedural objects (``pipeline.procedural``, the
categories of a world, :data:`WORLDS`; 2 to 15 parts), each seen at a partially-open state
(the paper's assumption: every door and drawer ajar), with the paper's augmentation — a
random rotation about z and a random shift — and one of ours for boxes cut from a predicted
segmentation: some drawers are seen by their front alone (:func:`drawer_fronts`). Labels come from the ground-truth joints
encoded on the fitted boxes (``pipeline.boxes``). The other learned models draw their
objects and states from here too (:func:`object_specs`, :func:`ajar_configuration`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from real2code_export import transforms as tf
from real2code_export.kinematics import world_joints, world_part_meshes
from real2code_export.model import JointType, Mesh

from ..boxes import ground_truth_program, part_boxes
from ..procedural import ALL_CATEGORIES, CATEGORIES, part_count_range
from .features import EDGES, box_features
from .network import JOINT_TYPES


def ajar_configuration(obj, rng: np.random.Generator, low: float = 0.2) -> dict[str, float]:
    """Every movable joint partly open: between ``low`` and 1 of its range from closed."""
    q = {}
    for j in obj.movable_joints:
        lo, hi = (j.limits.lower, j.limits.upper) if j.limits else (0.0, np.pi / 2)
        q[j.name] = float(lo + rng.uniform(low, 1.0) * (hi - lo))
    return q


def random_placement(rng: np.random.Generator) -> np.ndarray:
    """The paper's augmentation: a rotation about z and a shift."""
    return tf.make(tf.axis_angle_matrix([0, 0, 1], rng.uniform(-np.pi, np.pi)),
                   [*rng.uniform(-1.0, 1.0, 2), 0.0])


FRONT_ONLY = 0.25  # the share of drawers seen by their front alone


def drawer_fronts(obj, meshes: dict[str, Mesh], q, base, rng: np.random.Generator,
                  share: float = FRONT_ONLY) -> dict[str, Mesh]:
    """``meshes`` with ``share`` of the drawers cut to their front: the faces within a few
    centimetres of the drawer's front along its slide. A predicted segmentation often hands
    a pulled-out drawer's sides to the carcass behind it (they are slivers in every view),
    and the box of what is left is a panel, square to the carcass and standing out of it;
    trained on whole drawers only, the predictor read such a panel as a flap."""
    axes = world_joints(obj, q, base)
    out = dict(meshes)
    for j in obj.movable_joints:
        if j.type is not JointType.PRISMATIC or rng.random() >= share:
            continue
        mesh = meshes[j.child]
        along = mesh.vertices @ axes[j.name][0]  # the drawer opens along +axis
        keep = np.all(along[mesh.faces] >= along.max() - rng.uniform(0.01, 0.08), axis=1)
        used = np.unique(mesh.faces[keep])
        if len(used) < 8:
            continue
        remap = np.zeros(len(mesh.vertices), dtype=np.int64)
        remap[used] = np.arange(len(used))
        out[j.child] = Mesh(mesh.vertices[used], remap[mesh.faces[keep]])
    return out


def sample(obj, q, base, rng: np.random.Generator | None = None):
    """Features and labels of one object seen at ``q`` placed at ``base`` (with ``rng``,
    some drawers seen by their front alone)."""
    meshes = world_part_meshes(obj, q, base)
    if rng is not None:
        meshes = drawer_fronts(obj, meshes, q, base, rng)
    order = [p.name for p in obj.parts]
    boxes_by_name = part_boxes(meshes)
    boxes = [boxes_by_name[n] for n in order]
    program = ground_truth_program(obj, order, boxes, q, base)
    n = len(boxes)
    labels = {
        "root": program.root_geom,
        "type": np.full(n, -100), "idx": np.full(n, -100), "edge": np.full(n, -100),
        "sign": np.full(n, -100), "parent": np.full(n, -100),
    }
    for j in program.child_joints:
        labels["type"][j.box] = JOINT_TYPES.index(j.type)
        labels["idx"][j.box] = j.idx
        labels["sign"][j.box] = 0 if j.sign < 0 else 1
        labels["parent"][j.box] = program.parent_of(j)
        if j.type == "hinge":
            labels["edge"][j.box] = EDGES.index(tuple(j.edge))
    return box_features(boxes), labels


def _one(args):
    category, n_parts, seed = args
    from ..procedural import generate

    rng = np.random.default_rng(seed + 1_000_003)
    obj = generate(category, n_parts, seed)
    return sample(obj, ajar_configuration(obj, rng), random_placement(rng), rng)


# The worlds training draws from: categories, and the share of objects that are storage
# furniture (the widest range of layouts) before the rest is shared out equally. The shipped
# mask and occupancy networks (and every figure made with their views) are of
# ``real2code``; ``household`` adds the household categories.
WORLDS = {"real2code": CATEGORIES, "household": ALL_CATEGORIES}
STORAGE_SHARE = {"real2code": 0.6, "household": 0.5}


def object_specs(n_objects: int, seed: int, world: str = "real2code"
                 ) -> list[tuple[str, int | None, int]]:
    """A balanced mix of ``world``: storage furniture over 2..15 parts, and the other
    categories in equal shares of the rest."""
    if world not in WORLDS:
        raise ValueError(f"unknown world {world!r}; choose from {list(WORLDS)}")
    categories = WORLDS[world]
    rng = np.random.default_rng(seed)
    specs = []
    for k in range(n_objects):
        category = categories[0] if rng.random() < STORAGE_SHARE[world] else \
            categories[rng.integers(len(categories))]
        lo, hi = part_count_range(category)
        specs.append((category, int(rng.integers(lo, hi + 1)), seed * 1_000_000 + k))
    return specs


def make_dataset(n_objects: int, seed: int, workers: int = 2, cache: Path | None = None,
                 world: str = "real2code") -> list:
    """Samples for ``n_objects`` procedural objects of ``world``; ``cache`` keeps them
    between runs."""
    import pickle

    if cache is not None and cache.is_file():
        return pickle.loads(cache.read_bytes())
    specs = object_specs(n_objects, seed, world)
    if workers > 1:
        from multiprocessing import get_context

        with get_context("spawn").Pool(workers) as pool:
            data = pool.map(_one, specs, chunksize=32)
    else:
        data = [_one(s) for s in specs]
    if cache is not None:
        cache.parent.mkdir(parents=True, exist_ok=True)
        cache.write_bytes(pickle.dumps(data))
    return data
