"""Train the point-prompted mask network on rendered procedural objects, on the CPU.

    python -m pipeline.segment.train [--objects 1200] [--epochs 10] [--out PATH]
    python -m pipeline.segment.train --init PATH --seed 2 --epochs 6 --lr 1e-3  # go on
    python -m pipeline.segment.train --init PATH --cameras ring,handheld --sensors \
        clean,phone-lidar --rehearse 200  # other paths, the old ones replayed

As the paper fine-tunes SAM's decoder: each image comes with prompts sampled inside its
ground-truth part masks (a part drawn uniformly, then a pixel in it, so small drawers are
prompted as often as the carcass); the target is the mask of the whole rigid part under
the prompt; the loss is close to SAM's (cross-entropy + dice on the mask, squared error
on the predicted IoU), plus a dense one on the part centres the encoder's first channels
hold (``network.py``). Weights, configuration and the training record (time, validation IoU) are
saved together. ``--init`` continues from saved weights on freshly rendered objects (another
``--seed``), and the new record keeps the earlier ones under ``previous``: the shipped
weights' record lists the commands that reproduce them.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from ..training_cache import cache_file
from ..weights import save_weights
from .data import SHIPPED_CAMERAS, SHIPPED_SENSORS, SHIPPED_WORLD, View, make_views
from .features import SIZE, grid_features
from .learned import WEIGHTS

# The shipped network: wider at the coarse levels than the first one (16..64, dim 32; cheap,
# they run at 1/8 to 1/32 of the grid) and with the point head (fine = 16). A step of 8 images
# x 24 prompts takes about 0.55 s. The first network was underfitting (training-view IoU 0.737,
# validation 0.727); this one reaches 0.797 (docs/reconstruction.md).
DEFAULT_NETWORK = {"dim": 48, "widths": [16, 32, 48, 64, 96], "fine": 16}


def _features(view: View) -> np.ndarray:
    return grid_features(view.rgb, view.depth, view.rays())


def sample_prompts(mask: np.ndarray, n: int, rng: np.random.Generator, min_pixels: int = 6,
                   ) -> tuple[np.ndarray, np.ndarray]:
    """``n`` prompts (u, v in model grid coordinates) inside the parts of ``mask``, a part
    drawn uniformly then a pixel in it; and the part label under each."""
    labels, counts = np.unique(mask[mask > 0], return_counts=True)
    labels = labels[counts >= min_pixels]
    if len(labels) == 0:
        return np.zeros((0, 2)), np.zeros(0, dtype=int)
    chosen = rng.choice(labels, size=n)
    uv = np.empty((n, 2))
    for i, k in enumerate(chosen):
        rows, cols = np.nonzero(mask == k)
        j = rng.integers(len(rows))
        uv[i] = cols[j] + rng.uniform(0.2, 0.8), rows[j] + rng.uniform(0.2, 0.8)
    return uv, chosen.astype(int)


def centre_target(mask: np.ndarray, depth_channel: np.ndarray,
                  ) -> np.ndarray:
    """(3, SIZE/2, SIZE/2): for every pixel its part's centre in this view — the image
    centroid of the part's pixels (u, v in [-1, 1]) and their mean relative depth (the
    depth input channel); 0 on the background."""
    m = mask[1::2, 1::2]
    rel = depth_channel[1::2, 1::2]
    n = m.shape[0]
    axis = (np.arange(n) + 0.5) / n * 2 - 1
    out = np.zeros((3, n, n), np.float32)
    for k in np.unique(m[m > 0]):
        rows, cols = np.nonzero(m == k)
        out[:, rows, cols] = np.array([axis[cols].mean(), axis[rows].mean(),
                                       rel[rows, cols].mean()])[:, None]
    return out


def batch(views: list[View], prompts: int, rng: np.random.Generator):
    import torch

    x = np.stack([_features(v) for v in views])
    uv, target = [], []
    for v in views:  # every view holds a part (make_views keeps no empty one)
        p, lab = sample_prompts(v.mask, prompts, rng)
        uv.append(p)
        target.append(np.stack([v.mask == k for k in lab]))
    centres = np.stack([centre_target(v.mask, f[3]) for v, f in zip(views, x, strict=True)])
    return (torch.from_numpy(x), torch.from_numpy(np.stack(uv)).float(),
            torch.from_numpy(np.stack(target)).float(), torch.from_numpy(centres))


def centre_loss(embedding, centres):
    """Smooth L1 between the embedding's centre channels and the part centres, on the
    object's pixels."""
    import torch.nn.functional as F

    from .network import CENTRE

    fg = (centres.abs().sum(1, keepdim=True) > 0).float()
    err = F.smooth_l1_loss(embedding[:, :CENTRE], centres, reduction="none", beta=0.05)
    return (err * fg).sum() / (fg.sum() * CENTRE).clamp(min=1)


def losses(logits, iou_pred, target):
    """The mask loss (binary cross-entropy + dice) and SAM's IoU-prediction loss, at the
    logits' resolution (the target area-averaged to it: soft at part borders).

    SAM weighs a focal loss 20:1 against dice; trained from scratch on our CPU budget that
    kept the masks empty for too long (mean IoU 0.13 after 150 steps), so plain
    cross-entropy takes its place."""
    import torch
    import torch.nn.functional as F

    factor = target.shape[-1] // logits.shape[-1]
    if factor > 1:
        target = F.avg_pool2d(target, factor)
    prob = torch.sigmoid(logits)
    ce = F.binary_cross_entropy_with_logits(logits, target, reduction="none").mean((2, 3))
    inter = (prob * target).sum((2, 3))
    dice = 1 - (2 * inter + 1) / (prob.sum((2, 3)) + target.sum((2, 3)) + 1)
    hard, truth = (prob.detach() > 0.5).float(), (target > 0.5).float()
    iou = (hard * truth).sum((2, 3)) / ((hard + truth).clamp(max=1).sum((2, 3)) + 1e-6)
    iou_loss = (iou_pred - iou) ** 2
    return (ce + dice).mean(), iou_loss.mean(), iou


POINTS_PER_MASK = 256  # the point head's training points per mask ...
UNCERTAIN_SHARE = 0.75  # ... this share where the coarse mask is least sure (PointRend)


def sample_points(coarse, n: int = POINTS_PER_MASK, uncertain: float = UNCERTAIN_SHARE,
                  oversample: int = 3):
    """(B, P, n, 2) training points for the point head: of ``oversample * n`` uniform
    candidates per mask, the ``uncertain`` share whose coarse logit is nearest 0, and the
    rest uniform (PointRend's importance sampling)."""
    import torch

    from .network import bilinear

    b, p, h, _ = coarse.shape
    candidates = torch.rand(b, p, oversample * n, 2) * SIZE
    with torch.no_grad():
        at = bilinear(coarse.detach().flatten(0, 1)[:, None],
                      candidates.flatten(0, 1) * (h / SIZE)).view(b, p, -1)
    k = int(round(uncertain * n))
    pick = (-at.abs()).topk(k, dim=-1).indices
    unsure = torch.gather(candidates, 2, pick[..., None].expand(-1, -1, -1, 2))
    return torch.cat([unsure, torch.rand(b, p, n - k, 2) * SIZE], 2)


def at_points(target, points):
    """The full-resolution target masks (B, P, SIZE, SIZE) at ``points`` (B, P, N, 2):
    the value of the pixel each point falls in."""
    import torch

    cols = points[..., 0].long().clamp(0, SIZE - 1)
    rows = points[..., 1].long().clamp(0, SIZE - 1)
    return torch.gather(target.flatten(2), 2, rows * SIZE + cols)


def point_loss(net, logits, fine, x, uv, target):
    """Cross-entropy of the point head at points sampled on the coarse masks."""
    import torch.nn.functional as F

    points = sample_points(logits)
    out = net.point_logits(logits, fine, x, uv, points)
    return F.binary_cross_entropy_with_logits(out, at_points(target, points))


def full_masks(net, logits, fine, x, uv):
    """Logits (B, P, SIZE, SIZE) of the final masks: the point head at every pixel centre
    (the coarse logits, upsampled, without one)."""
    import torch
    import torch.nn.functional as F

    if not net.fine:
        return F.interpolate(logits, size=(SIZE, SIZE), mode="bilinear", align_corners=False)
    b, p = uv.shape[:2]
    centres = torch.arange(SIZE, dtype=torch.float32) + 0.5
    grid = torch.stack(torch.meshgrid(centres, centres, indexing="xy"), -1).view(1, 1, -1, 2)
    return net.point_logits(logits, fine, x, uv, grid.expand(b, p, -1, -1)).view(
        b, p, SIZE, SIZE)


def validate(net, views: list[View], seed: int = 0, prompts: int = 8) -> dict[str, float]:
    """Mean IoU of the final masks at full resolution (and of the coarse ones) and the
    correlation of the predicted IoU with the coarse masks' true IoU."""
    import torch

    net.eval()
    rng = np.random.default_rng(seed)
    ious, coarse_ious, preds = [], [], []
    with torch.no_grad():
        for s in range(0, len(views), 16):
            x, uv, target, _ = batch(views[s:s + 16], prompts, rng)
            logits, iou_pred = net.decode(net.encode(x), x, uv)
            _, _, iou = losses(logits, iou_pred, target)
            coarse_ious.append(iou.numpy().ravel())
            preds.append(iou_pred.numpy().ravel())
            final = full_masks(net, logits, net.encode_fine(x), x, uv) > 0
            truth = target > 0.5
            inter = (final & truth).sum((2, 3)).float()
            union = (final | truth).sum((2, 3)).float().clamp(min=1)
            ious.append((inter / union).numpy().ravel())
    net.train()
    ious, coarse_ious = np.concatenate(ious), np.concatenate(coarse_ious)
    preds = np.concatenate(preds)
    return {"mean_iou": float(ious.mean()), "iou_over_0.9": float((ious > 0.9).mean()),
            "coarse_mean_iou": float(coarse_ious.mean()),
            "iou_prediction_corr": float(np.corrcoef(coarse_ious, preds)[0, 1])}


def _cached(cache_dir: Path | None, tag: str, make):
    """``make()``, kept in ``cache_dir`` between runs (rendering is the slow part of a rerun)."""
    import pickle

    if cache_dir is None:
        return make()
    path = cache_file(cache_dir, f"segment_{tag}")
    if path.is_file():
        return pickle.loads(path.read_bytes())
    data = make()
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(pickle.dumps(data))
    return data


def recorded_world(record: dict | None) -> str:
    """The world (``pipeline.predictors.data.WORLDS``) a training record's objects came
    from: weights between two trainings have their fine-tuning's (whose data held the
    rehearsal of the other's); a record that names none predates worlds."""
    if not record:
        return SHIPPED_WORLD
    if "interpolated" in record:
        return recorded_world(record["interpolated"].get("new"))
    return record.get("world", SHIPPED_WORLD)


def _mix_tag(cameras, sensors, world: str) -> str:
    """What a cache name adds for views not drawn as the first shipped weights' were."""
    tag = "" if (tuple(cameras), tuple(sensors)) == (SHIPPED_CAMERAS, SHIPPED_SENSORS) else \
        "_" + "-".join((*cameras, *sensors)).replace(".", "_").replace("/", "_")
    return tag if world == SHIPPED_WORLD else f"{tag}_{world}"


def _union(*lists) -> list[str]:
    return list(dict.fromkeys(x for xs in lists for x in xs))


def train(n_objects: int, epochs: int, seed: int, out: Path, *, images_per_batch: int = 8,
          prompts_per_image: int = 24, workers: int = 2, views_per_object: int = 4,
          network_config: dict | None = None, lr: float = 3e-3,
          cache_dir: Path | None = None, init: Path | None = None,
          cameras: tuple[str, ...] = SHIPPED_CAMERAS,
          sensors: tuple[str, ...] = SHIPPED_SENSORS, rehearse: int = 0,
          validation_objects: int | None = None, world: str = SHIPPED_WORLD) -> dict:
    """Train (or, with ``init``, go on training) and save to ``out``; after every epoch but
    the last the weights so far go beside it (``NAME.epochK.pt``), to compare or resume.

    ``rehearse`` adds that many of the ``init`` weights' own training objects, drawn as
    theirs were (their record's seed, world, cameras and sensors), to the new views: fine-tuning on
    other paths and sensors alone makes the network forget what it did well (issue 20's
    first fine-tuning lost 0.035 mask IoU on the clean front arc with 1/16 of its views
    drawn so). ``validation_objects``: how many held-out objects the validation renders
    (default 40, or 1 in 20 of the training objects where that is more). ``world``: the
    categories the new objects (and the validation's) are drawn from, recorded."""
    import torch

    from .network import build_network

    torch.manual_seed(seed)
    torch.set_num_threads(max(1, workers))
    t0 = time.perf_counter()
    previous, start = None, None
    if init is not None:  # go on from saved weights, keeping their network and history
        from .learned import LearnedSegmenter

        start = LearnedSegmenter.load(init)
        previous = start.config.get("training")
    elif rehearse:
        raise ValueError("--rehearse needs --init: it replays the initial weights' own data")
    from ..predictors.data import WORLDS

    if world not in WORLDS:
        raise ValueError(f"unknown world {world!r}; choose from {list(WORLDS)}")
    mix = _mix_tag(cameras, sensors, world)
    views = _cached(cache_dir, f"train_{n_objects}_{seed}_{views_per_object}{mix}",
                    lambda: make_views(n_objects, seed, views_per_object, workers, cameras,
                                       sensors, world))
    n_val = validation_objects or max(40, n_objects // 20)
    val = _cached(cache_dir, f"val_{n_val}_{seed + 7919}{mix}",
                  lambda: make_views(n_val, seed + 7919, 2, workers, cameras, sensors, world))
    rehearsal = None
    if rehearse:
        old = start.config.get("input", {})
        rehearsal = {"objects": rehearse, "seed": int((previous or {}).get("seed", 1)),
                     "cameras": old.get("cameras", list(SHIPPED_CAMERAS)),
                     "sensors": old.get("sensors", list(SHIPPED_SENSORS)),
                     "world": recorded_world(previous)}
        old_mix = (tuple(rehearsal["cameras"]), tuple(rehearsal["sensors"]))
        tag = _mix_tag(*old_mix, rehearsal["world"])
        views = views + _cached(
            cache_dir, f"train_{rehearse}_{rehearsal['seed']}_{views_per_object}{tag}",
            lambda: make_views(rehearse, rehearsal["seed"], views_per_object, workers,
                               *old_mix, rehearsal["world"]))
    t_data = time.perf_counter() - t0
    print(f"{len(views)} training views, {len(val)} validation views in {t_data:.0f} s",
          flush=True)
    if start is not None:
        net = start.network.train()
        config = {"network": start.config["network"]}
    else:
        config = {"network": network_config or DEFAULT_NETWORK}
        net = build_network(**{**config["network"],
                               "widths": tuple(config["network"]["widths"])})
    config["input"] = {"window": "object",  # what make_views cuts and how its views were taken
                       "cameras": _union(cameras, rehearsal["cameras"] if rehearsal else []),
                       "sensors": _union(sensors, rehearsal["sensors"] if rehearsal else [])}
    opt = torch.optim.AdamW(net.parameters(), lr=lr, weight_decay=1e-4)
    per_epoch = (len(views) + images_per_batch - 1) // images_per_batch
    sched = torch.optim.lr_scheduler.OneCycleLR(opt, max_lr=lr, total_steps=epochs * per_epoch,
                                                pct_start=0.15)
    rng = np.random.default_rng(seed)
    history, validation = [], None

    def record(validation: dict) -> dict:
        out = {
            "objects": n_objects, "world": world, "views": len(views),
            "epochs": len(history), "seed": seed,
            "images_per_batch": images_per_batch, "prompts_per_image": prompts_per_image,
            "data_seconds": round(t_data, 1),
            "total_seconds": round(time.perf_counter() - t0, 1),
            "validation": validation, "final_loss": history[-1] if history else None,
            "parameters": sum(p.numel() for p in net.parameters()),
            "torch_threads": torch.get_num_threads(), "lr": lr,
        }
        if rehearsal is not None:
            out["rehearsal"] = rehearsal
        if previous is not None:
            out["previous"] = previous
        return out

    for epoch in range(epochs):
        order = rng.permutation(len(views))
        total, t_epoch = 0.0, time.perf_counter()
        for s in range(0, len(order), images_per_batch):
            x, uv, target, centres = batch([views[i] for i in order[s:s + images_per_batch]],
                                           prompts_per_image, rng)
            embedding = net.encode(x)
            logits, iou_pred = net.decode(embedding, x, uv)
            mask_loss, iou_loss, _ = losses(logits, iou_pred, target)
            loss = mask_loss + iou_loss + centre_loss(embedding, centres)
            if net.fine:
                loss = loss + point_loss(net, logits, net.encode_fine(x), x, uv, target)
            opt.zero_grad()
            loss.backward()
            opt.step()
            sched.step()
            total += loss.item()
            step = s // images_per_batch + 1
            if step % 25 == 0:
                print(f"  step {step}/{per_epoch}  loss {total / step:.4f}  "
                      f"{time.perf_counter() - t_epoch:.0f} s", flush=True)
        history.append(total / per_epoch)
        validation = validate(net, val)
        print(f"epoch {epoch + 1:3d}  loss {history[-1]:.4f}  {time.perf_counter() - t_epoch:.0f} s"
              f"  val {validation}", flush=True)
        if epoch + 1 < epochs:
            save_weights(net, {**config, "training": record(validation)},
                         out.with_name(f"{out.stem}.epoch{epoch + 1}{out.suffix}"))
    config["training"] = record(validation if epochs else validate(net, val))
    save_weights(net, config, out)
    return config["training"]


def main(argv=None) -> None:
    from ..predictors.data import WORLDS

    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--objects", type=int, default=1200)
    p.add_argument("--epochs", type=int, default=10)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--lr", type=float, default=3e-3, help="peak learning rate")
    p.add_argument("--init", type=Path, default=None,
                   help="continue from these weights (e.g. the shipped ones)")
    p.add_argument("--dim", type=int, default=DEFAULT_NETWORK["dim"],
                   help="embedding channels (a new network; ignored with --init)")
    p.add_argument("--widths", default=",".join(map(str, DEFAULT_NETWORK["widths"])),
                   help="encoder widths per level, comma-separated (ignored with --init)")
    p.add_argument("--fine", type=int, default=DEFAULT_NETWORK["fine"],
                   help="fine feature channels of the point head, 0 for none (ignored with "
                        "--init)")
    p.add_argument("--out", type=Path, default=WEIGHTS)
    p.add_argument("--cache-dir", type=Path, default=None,
                   help="keep rendered views here between runs")
    p.add_argument("--cameras", default=",".join(SHIPPED_CAMERAS),
                   help="camera paths to draw each object's from (pipeline.camera_paths)")
    p.add_argument("--sensors", default=",".join(SHIPPED_SENSORS),
                   help="capture presets or sensor JSON files to draw each object's from")
    p.add_argument("--rehearse", type=int, default=0,
                   help="with --init: also train on this many of the initial weights' own "
                        "training objects, drawn as theirs were (so it does not forget them)")
    p.add_argument("--world", default=SHIPPED_WORLD, choices=sorted(WORLDS),
                   help="the categories the new objects are drawn from (a rehearsal replays "
                        "the world of the --init weights' record)")
    p.add_argument("--validation-objects", type=int, default=None,
                   help="held-out objects to validate on (default 40, or 1 in 20 of "
                        "--objects where that is more)")
    args = p.parse_args(argv)
    if args.rehearse and args.init is None:
        p.error("--rehearse needs --init: it replays the initial weights' own data")
    record = train(args.objects, args.epochs, args.seed, args.out, workers=args.workers,
                   cache_dir=args.cache_dir, lr=args.lr, init=args.init,
                   cameras=tuple(args.cameras.split(",")),
                   sensors=tuple(args.sensors.split(",")), rehearse=args.rehearse,
                   validation_objects=args.validation_objects, world=args.world,
                   network_config={"dim": args.dim,
                                   "widths": [int(w) for w in args.widths.split(",")],
                                   "fine": args.fine})
    print(json.dumps(record, indent=1))


if __name__ == "__main__":
    main()
