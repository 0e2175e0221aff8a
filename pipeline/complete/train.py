"""Train the shape-completion occupancy network on procedural parts, on the CPU.

    python -m pipeline.complete.train [--objects 1200] [--steps 1500] [--out PATH]

Data: procedural objects of every category (the joint predictor's mix,
``pipeline.predictors.data.object_specs``; seeds below the held-out test offset),
each ajar and randomly placed, every part seen partially from 12 ring views
(:mod:`pipeline.complete.data`). Loss: binary cross-entropy on the query occupancies.
The weights, the configuration and the training record (time, validation IoU) are saved
together; the defaults reproduce the shipped weights.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from ..training_cache import cache_file
from ..weights import save_weights
from .data import Sample, object_samples
from .learned import WEIGHTS

QUERIES_PER_STEP = 2048


def _object(spec) -> list[Sample]:
    from ..predictors.data import ajar_configuration, random_placement
    from ..procedural import generate

    category, n_parts, seed = spec
    rng = np.random.default_rng(seed + 2_000_003)
    obj = generate(category, n_parts, seed)
    return object_samples(obj, rng, q=ajar_configuration(obj, rng), base=random_placement(rng))


def make_dataset(n_objects: int, seed: int, workers: int = 2,
                 cache: Path | None = None) -> list[Sample]:
    """Samples of ``n_objects`` procedural objects; ``cache`` keeps them between runs."""
    import pickle

    from ..predictors.data import object_specs

    if cache is not None and cache.is_file():
        return pickle.loads(cache.read_bytes())
    specs = object_specs(n_objects, seed)
    if workers > 1:
        from multiprocessing import get_context

        with get_context("spawn").Pool(workers) as pool:
            per_object = pool.map(_object, specs, chunksize=16)
    else:
        per_object = [_object(s) for s in specs]
    data = [s for samples in per_object for s in samples]
    if cache is not None:
        cache.parent.mkdir(parents=True, exist_ok=True)
        cache.write_bytes(pickle.dumps(data))
    return data


def _batch(samples: list[Sample], rng: np.random.Generator, n_queries: int):
    import torch

    pick = [rng.choice(len(s.queries), n_queries, replace=False) for s in samples]
    points = torch.from_numpy(np.stack([s.points for s in samples]).astype(np.float32))
    size = torch.from_numpy(np.stack([s.size for s in samples]))
    queries = torch.from_numpy(np.stack([s.queries[i] for s, i in zip(samples, pick, strict=True)])
                               .astype(np.float32))
    occupied = torch.from_numpy(np.stack([s.occupied[i] for s, i in zip(samples, pick, strict=True)])
                                .astype(np.float32))
    return points, size, queries, occupied


def iou(network, samples: list[Sample], batch_size: int = 32) -> float:
    """Intersection over union of predicted and true occupancy over all query points."""
    import torch

    network.eval()
    inter = union = 0
    with torch.no_grad():
        for s in range(0, len(samples), batch_size):
            chunk = samples[s:s + batch_size]
            points, size, queries, occupied = _batch(chunk, np.random.default_rng(0),
                                                     len(chunk[0].queries))
            pred = network(points, size, queries) > 0
            truth = occupied > 0.5
            inter += int((pred & truth).sum())
            union += int((pred | truth).sum())
    network.train()
    return inter / max(1, union)


def train(n_objects: int, steps: int, seed: int, out: Path, batch_size: int = 16,
          workers: int = 2, threads: int = 1, val_objects: int | None = None,
          network_config: dict | None = None, cache_dir: Path | None = None) -> dict:
    import torch
    import torch.nn.functional as F

    from .network import build_network

    torch.manual_seed(seed)
    # One thread: on two cores shared with other work, two threads wait on each other.
    torch.set_num_threads(max(1, threads))
    t0 = time.perf_counter()
    def cache(tag: str, n: int, s: int) -> Path | None:
        return cache_file(cache_dir, f"completion_{tag}_{n}_{s}")

    n_val = val_objects or max(40, n_objects // 20)
    data = make_dataset(n_objects, seed, workers, cache("train", n_objects, seed))
    val = make_dataset(n_val, seed + 7919, workers, cache("val", n_val, seed + 7919))
    t_data = time.perf_counter() - t0
    print(f"{len(data)} training parts, {len(val)} validation parts in {t_data:.0f} s",
          flush=True)
    config = {"network": network_config or {}}
    net = build_network(**config["network"])
    opt = torch.optim.AdamW(net.parameters(), lr=2e-3, weight_decay=1e-4)
    sched = torch.optim.lr_scheduler.OneCycleLR(opt, max_lr=2e-3, total_steps=max(1, steps),
                                                pct_start=0.1)
    rng = np.random.default_rng(seed)
    running = []
    for step in range(steps):
        pick = rng.choice(len(data), batch_size, replace=False)
        points, size, queries, occupied = _batch([data[i] for i in pick], rng, QUERIES_PER_STEP)
        loss = F.binary_cross_entropy_with_logits(net(points, size, queries), occupied)
        opt.zero_grad()
        loss.backward()
        opt.step()
        sched.step()
        running.append(loss.item())
        if (step + 1) % 100 == 0 or step + 1 == steps:
            print(f"step {step + 1:5d}  loss {np.mean(running[-100:]):.4f}  "
                  f"{time.perf_counter() - t0:.0f} s", flush=True)
            save_weights(net, config, out.with_name(out.stem + ".checkpoint.pt"))
    record = {
        "objects": n_objects, "parts": len(data), "steps": steps, "batch_size": batch_size,
        "seed": seed, "data_seconds": round(t_data, 1),
        "total_seconds": round(time.perf_counter() - t0, 1),
        "val_parts": len(val), "val_iou": round(iou(net, val), 4),
        "final_loss": round(float(np.mean(running[-100:])), 4) if running else None,
        "parameters": sum(p.numel() for p in net.parameters()),
        "torch_threads": torch.get_num_threads(),
    }
    config["training"] = record
    save_weights(net, config, out)
    out.with_name(out.stem + ".checkpoint.pt").unlink(missing_ok=True)
    return record


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--objects", type=int, default=1200)
    p.add_argument("--threads", type=int, default=1)
    p.add_argument("--steps", type=int, default=1500)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--out", type=Path, default=WEIGHTS)
    p.add_argument("--cache-dir", type=Path, default=None,
                   help="keep generated samples here between runs")
    args = p.parse_args(argv)
    record = train(args.objects, args.steps, args.seed, args.out, workers=args.workers,
                   threads=args.threads, cache_dir=args.cache_dir)
    print(json.dumps(record, indent=1))


if __name__ == "__main__":
    main()
