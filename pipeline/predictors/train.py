"""Train the learned joint predictor on procedural objects, on the CPU.

    python -m pipeline.predictors.train [--objects 6000] [--epochs 40] [--workers 2]
        [--threads N] [--world real2code|household] [--init WEIGHTS --lr 5e-4] [--out PATH]

Data: :mod:`.data` (procedural objects, ajar, augmented, labelled from their true joints).
The weights, the configuration and the training record (time, validation accuracy) are
written together.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from ..training_cache import cache_file
from ..weights import save_weights
from .data import WORLDS, make_dataset
from .features import EDGES
from .learned import WEIGHTS
from .network import JOINT_TYPES, build_network


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

    from .learned import decode

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
          cache_dir: Path | None = None, threads: int | None = None,
          init: Path | None = None, lr: float = 2e-3, world: str = "real2code") -> dict:
    """Generate the data with ``workers`` processes and train with ``threads`` torch threads
    (default: as many as workers), from scratch or from the weights in ``init`` (their
    network's shape; their record is kept under ``training.init``), at peak rate ``lr``, on
    objects of ``world`` (``data.WORLDS``)."""
    import torch

    torch.manual_seed(seed)
    torch.set_num_threads(max(1, threads or workers))
    t0 = time.perf_counter()
    def cache(tag: str, n: int, s: int) -> Path | None:
        return cache_file(cache_dir, f"joints_{tag}_{world}_{n}_{s}")

    data = make_dataset(n_objects, seed, workers, cache("train", n_objects, seed), world)
    n_val = max(50, n_objects // 10)
    val = make_dataset(n_val, seed + 7919, workers, cache("val", n_val, seed + 7919), world)
    t_data = time.perf_counter() - t0
    if init is not None:
        from ..weights import load_network

        net, init_config = load_network(init, "joint-predictor", lambda c: build_network(**c),
                                        "python -m pipeline.predictors.train")
        net.train()
        config = {"network": init_config["network"]}
    else:
        config = {"network": network_config or {"d_model": 96, "layers": 3, "heads": 4}}
        net = build_network(**config["network"])
    opt = torch.optim.AdamW(net.parameters(), lr=lr, weight_decay=1e-4)
    steps = epochs * ((len(data) + batch_size - 1) // batch_size)
    sched = torch.optim.lr_scheduler.OneCycleLR(opt, max_lr=lr, total_steps=max(1, steps))
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
        "objects": n_objects, "epochs": epochs, "seed": seed, "world": world,
        "data_seconds": round(t_data, 1), "total_seconds": round(time.perf_counter() - t0, 1),
        "val_exact_program_accuracy": exact_accuracy(net, val),
        "final_loss": history[-1] if history else None,
        "parameters": sum(p.numel() for p in net.parameters()),
        "torch_threads": torch.get_num_threads(),
        "peak_lr": lr,
    }
    if init is not None:
        record["init"] = {"path": str(init), "training": init_config.get("training")}
    config["training"] = record
    save_weights(net, config, out)
    return record


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--objects", type=int, default=6000)
    p.add_argument("--epochs", type=int, default=40)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--workers", type=int, default=2, help="processes generating the data")
    p.add_argument("--threads", type=int, default=None,
                   help="torch threads for training (default: as many as --workers)")
    p.add_argument("--out", type=Path, default=WEIGHTS)
    p.add_argument("--init", type=Path, default=None,
                   help="fine-tune these weights instead of starting from scratch")
    p.add_argument("--lr", type=float, default=2e-3, help="peak learning rate")
    p.add_argument("--world", default="real2code", choices=sorted(WORLDS),
                   help="the categories trained on: real2code (the paper's five) or household "
                        "(those and the household ones)")
    p.add_argument("--cache-dir", type=Path, default=None,
                   help="keep generated samples here between runs")
    args = p.parse_args(argv)
    record = train(args.objects, args.epochs, args.seed, args.out, workers=args.workers,
                   cache_dir=args.cache_dir, threads=args.threads, init=args.init, lr=args.lr,
                   world=args.world)
    print(json.dumps(record, indent=1))


if __name__ == "__main__":
    main()
