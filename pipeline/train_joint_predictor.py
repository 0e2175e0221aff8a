"""Train the learned joint predictor on procedural objects, on the CPU.

    python -m pipeline.train_joint_predictor [--objects 6000] [--epochs 40] [--out PATH]

Data: objects from ``pipeline.procedural`` (every category, 2 to 15 parts), each seen at a
partially-open state (the paper's assumption: every door and drawer ajar), with the
paper's augmentation — a random rotation about z and a random shift — and one of ours
for boxes cut from a predicted segmentation: some drawers are seen by their front alone
(``drawer_fronts``). Labels come from the ground-truth joints encoded on the fitted boxes
(``pipeline.boxes``). The weights, the configuration and the training record (time,
validation accuracy) are written together.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from real2code_export import transforms as tf
from real2code_export.kinematics import world_joints, world_part_meshes
from real2code_export.model import JointType, Mesh

from .boxes import ground_truth_program, part_boxes
from .predictors.features import EDGES, box_features
from .predictors.learned import JOINT_TYPES, WEIGHTS, build_network
from .weights import save_weights


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
    from .procedural import generate

    rng = np.random.default_rng(seed + 1_000_003)
    obj = generate(category, n_parts, seed)
    return sample(obj, ajar_configuration(obj, rng), random_placement(rng), rng)


def object_specs(n_objects: int, seed: int) -> list[tuple[str, int | None, int]]:
    """A balanced mix: storage furniture over 2..15 parts, and the other categories."""
    from .procedural import CATEGORIES, part_count_range

    rng = np.random.default_rng(seed)
    specs = []
    for k in range(n_objects):
        category = CATEGORIES[0] if rng.random() < 0.6 else CATEGORIES[rng.integers(len(CATEGORIES))]
        lo, hi = part_count_range(category)
        specs.append((category, int(rng.integers(lo, hi + 1)), seed * 1_000_000 + k))
    return specs


def make_dataset(n_objects: int, seed: int, workers: int = 2, cache: Path | None = None) -> list:
    """Samples for ``n_objects`` procedural objects; ``cache`` keeps them between runs."""
    import pickle

    if cache is not None and cache.is_file():
        return pickle.loads(cache.read_bytes())
    specs = object_specs(n_objects, seed)
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


def _batch(samples):
    import torch

    n = max(f.shape[0] for f, _ in samples)
    b = len(samples)
    x = torch.zeros(b, n, samples[0][0].shape[1])
    pad = torch.ones(b, n, dtype=torch.bool)
    y = {k: torch.full((b, n), -100, dtype=torch.long) for k in
         ("type", "idx", "edge", "sign", "parent")}
    root = torch.zeros(b, dtype=torch.long)
    for i, (f, lab) in enumerate(samples):
        m = f.shape[0]
        x[i, :m] = torch.from_numpy(f)
        pad[i, :m] = False
        root[i] = lab["root"]
        for k in y:
            y[k][i, :m] = torch.from_numpy(lab[k])
    return x, pad, root, y


def _loss(out, root, y):
    import torch
    import torch.nn.functional as F

    loss = F.cross_entropy(out["root"], root)
    for k in ("type", "idx"):
        loss = loss + F.cross_entropy(out[k].flatten(0, 1), y[k].flatten(), ignore_index=-100)
    idx = y["idx"].clamp(min=0)
    gather = idx[..., None, None]
    edge = torch.gather(out["edge"], 2, gather.expand(-1, -1, 1, len(EDGES))).squeeze(2)
    sign = torch.gather(out["sign"], 2, gather.expand(-1, -1, 1, 2)).squeeze(2)
    loss = loss + F.cross_entropy(edge.flatten(0, 1), y["edge"].flatten(), ignore_index=-100)
    loss = loss + F.cross_entropy(sign.flatten(0, 1), y["sign"].flatten(), ignore_index=-100)
    loss = loss + F.cross_entropy(out["parent"].flatten(0, 1), y["parent"].flatten(),
                                  ignore_index=-100)
    return loss


def exact_accuracy(network, data) -> float:
    """Fraction of objects whose whole program is predicted exactly."""
    import torch

    from .predictors.learned import decode

    network.eval()
    hits = 0
    with torch.no_grad():
        for f, lab in data:
            out = network(torch.from_numpy(f)[None], torch.zeros(1, f.shape[0], dtype=torch.bool))
            prog = decode({k: v[0].numpy() for k, v in out.items()}, f.shape[0])
            ok = prog.root_geom == lab["root"]
            for j in prog.child_joints:
                ok &= JOINT_TYPES.index(j.type) == lab["type"][j.box]
                ok &= j.idx == lab["idx"][j.box] and (1 if j.sign > 0 else 0) == lab["sign"][j.box]
                ok &= prog.parent_of(j) == lab["parent"][j.box]
                if j.type == "hinge":
                    ok &= EDGES.index(tuple(j.edge)) == lab["edge"][j.box]
            hits += bool(ok)
    network.train()
    return hits / max(1, len(data))


def train(n_objects: int, epochs: int, seed: int, out: Path, batch_size: int = 64,
          workers: int = 2, network_config: dict | None = None,
          cache_dir: Path | None = None) -> dict:
    import torch

    torch.manual_seed(seed)
    torch.set_num_threads(max(1, workers))
    t0 = time.perf_counter()
    def cache(tag: str, n: int, s: int) -> Path | None:
        return cache_dir / f"joints_{tag}_{n}_{s}.pkl" if cache_dir else None

    data = make_dataset(n_objects, seed, workers, cache("train", n_objects, seed))
    n_val = max(50, n_objects // 10)
    val = make_dataset(n_val, seed + 7919, workers, cache("val", n_val, seed + 7919))
    t_data = time.perf_counter() - t0
    config = {"network": network_config or {"d_model": 96, "layers": 3, "heads": 4}}
    net = build_network(**config["network"])
    opt = torch.optim.AdamW(net.parameters(), lr=2e-3, weight_decay=1e-4)
    steps = epochs * ((len(data) + batch_size - 1) // batch_size)
    sched = torch.optim.lr_scheduler.OneCycleLR(opt, max_lr=2e-3, total_steps=max(1, steps))
    rng = np.random.default_rng(seed)
    history = []
    for epoch in range(epochs):
        order = rng.permutation(len(data))
        total = 0.0
        for s in range(0, len(order), batch_size):
            x, pad, root, y = _batch([data[i] for i in order[s:s + batch_size]])
            loss = _loss(net(x, pad), root, y)
            opt.zero_grad()
            loss.backward()
            opt.step()
            sched.step()
            total += loss.item() * len(x)
        history.append(total / len(data))
        if epoch % 5 == 4 or epoch == epochs - 1:
            print(f"epoch {epoch + 1:3d}  loss {history[-1]:.4f}  "
                  f"val exact {exact_accuracy(net, val):.3f}", flush=True)
    record = {
        "objects": n_objects, "epochs": epochs, "seed": seed,
        "data_seconds": round(t_data, 1), "total_seconds": round(time.perf_counter() - t0, 1),
        "val_exact_program_accuracy": exact_accuracy(net, val),
        "final_loss": history[-1] if history else None,
        "parameters": sum(p.numel() for p in net.parameters()),
        "torch_threads": torch.get_num_threads(),
    }
    config["training"] = record
    save_weights(net, config, out)
    return record


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--objects", type=int, default=6000)
    p.add_argument("--epochs", type=int, default=40)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--out", type=Path, default=WEIGHTS)
    p.add_argument("--cache-dir", type=Path, default=None,
                   help="keep generated samples here between runs")
    args = p.parse_args(argv)
    record = train(args.objects, args.epochs, args.seed, args.out, workers=args.workers,
                   cache_dir=args.cache_dir)
    print(json.dumps(record, indent=1))


if __name__ == "__main__":
    main()
