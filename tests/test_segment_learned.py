"""The mask network trained in this repository: its training step learns, its shipped
weights load with their training record, and on held-out procedural captures the
prompted segmentation finds the rigid parts."""

from __future__ import annotations

import numpy as np
import pytest

torch = pytest.importorskip("torch")

from pipeline.evaluate_articulation import procedural_cases  # noqa: E402
from pipeline.render import render_object  # noqa: E402
from pipeline.segment import segment  # noqa: E402
from pipeline.segment.data import make_views  # noqa: E402
from pipeline.segment.evaluate import matched_part_iou  # noqa: E402
from pipeline.segment.learned import LearnedSegmenter  # noqa: E402
from pipeline.segment.network import build_network  # noqa: E402
from pipeline.segment.train import WEIGHTS, batch, centre_loss, losses, sample_prompts  # noqa: E402
from pipeline.training_cache import code_version  # noqa: E402
from real2code_export.errors import FormatError  # noqa: E402


def test_prompts_fall_inside_their_parts():
    mask = np.zeros((16, 16), np.uint8)
    mask[2:5, 2:5] = 1  # a small part is prompted as often as the big one
    mask[6:16, :] = 2
    uv, labels = sample_prompts(mask, 400, np.random.default_rng(0))
    assert np.all(mask[uv[:, 1].astype(int), uv[:, 0].astype(int)] == labels)
    assert 0.4 < (labels == 1).mean() < 0.6


def test_training_steps_fit_a_small_batch():
    torch.manual_seed(0)
    views = make_views(1, seed=3, views_per_object=2, workers=1)
    net = build_network(dim=16, widths=(8, 12, 16, 24, 32))
    opt = torch.optim.Adam(net.parameters(), 3e-3)
    rng = np.random.default_rng(0)
    x, uv, target, centres = batch(views, 8, rng)
    first = None
    for _ in range(30):
        embedding = net.encode(x)
        logits, iou = net.decode(embedding, x, uv)
        mask_loss, iou_loss, _ = losses(logits, iou, target)
        loss = mask_loss + iou_loss + centre_loss(embedding, centres)
        opt.zero_grad()
        loss.backward()
        opt.step()
        first = first if first is not None else loss.item()
    assert logits.shape == (len(views), 8, 64, 64) and iou.shape == (len(views), 8)
    assert loss.item() < 0.6 * first


def test_training_script_writes_loadable_weights(tmp_path):
    from pipeline.segment.train import train

    out = tmp_path / "segmenter.pt"
    # two validation objects, not the default 40: rendering them was most of this test's time
    record = train(2, 1, 0, out, images_per_batch=4, prompts_per_image=4, workers=1,
                   views_per_object=2, network_config={"dim": 16, "widths": [8, 12, 16, 24, 32]},
                   validation_objects=2)
    assert record["parameters"] > 0 and record["epochs"] == 1
    segmenter = LearnedSegmenter.load(out)
    assert segmenter is not None
    assert record["world"] == "real2code"
    # going on from those weights keeps their network and their record; rehearsing adds
    # their own first object (seed 0, their world), and every epoch but the last leaves a
    # checkpoint
    more = tmp_path / "more.pt"
    again = train(2, 2, 5, more, images_per_batch=4, prompts_per_image=4, workers=1,
                  views_per_object=2, lr=1e-3, init=out, rehearse=1, validation_objects=2,
                  world="household")
    assert again["previous"]["seed"] == 0 and again["seed"] == 5 and again["lr"] == 1e-3
    assert again["rehearsal"]["seed"] == 0 and again["views"] == 2 * 2 + 1 * 2
    assert again["world"] == "household" and again["rehearsal"]["world"] == "real2code"
    assert LearnedSegmenter.load(tmp_path / "more.epoch1.pt").config["training"]["epochs"] == 1
    with pytest.raises(ValueError, match="needs --init"):
        train(2, 1, 5, tmp_path / "x.pt", workers=1, rehearse=1)
    with pytest.raises(ValueError, match="unknown world 'kitchen'"):
        train(2, 1, 5, tmp_path / "x.pt", workers=1, world="kitchen")
    continued = LearnedSegmenter.load(more)
    assert continued.config["network"] == segmenter.config["network"]
    before = segmenter.network.state_dict()
    after = continued.network.state_dict()
    assert any(not torch.equal(before[k], after[k]) for k in before)  # it did train


def test_the_world_a_record_names():
    """A rehearsal replays the world of its initial weights: their record's, the
    fine-tuning's for weights between two trainings, the paper's for records before worlds."""
    from pipeline.segment.train import recorded_world

    assert recorded_world(None) == "real2code"
    assert recorded_world({"seed": 1}) == "real2code"
    assert recorded_world({"seed": 1, "world": "household"}) == "household"
    assert recorded_world({"interpolated": {"alpha": 0.5, "old": {"seed": 1},
                                            "new": {"world": "household"}}}) == "household"


def test_views_of_a_world():
    """``world`` draws the objects from that world's categories (the default, the paper's,
    draws as before)."""
    from pipeline.predictors.data import object_specs
    from pipeline.procedural import CATEGORIES
    from pipeline.segment.data import _one

    (category, n, seed), = object_specs(1, 0, "household")
    assert category not in CATEGORIES  # seed 0 draws a household category there
    views = make_views(1, 0, views_per_object=1, workers=1, world="household")
    alone = _one((category, n, seed, 1, ("front-arc",), ("clean",)))
    assert len(views) == 1 and np.array_equal(views[0].mask, alone[0].mask)
    (paper, *_), = object_specs(1, 0)
    assert paper in CATEGORIES


def test_views_from_other_paths_and_sensors_and_the_comparison(tmp_path):
    """Training views from a ring through a noisy sensor: masks as rendered, depth cleaned
    (no fault survives as a speck); and the comparison of two networks on such views."""
    from pipeline.segment.compare import compare

    views = make_views(1, seed=4, views_per_object=3, workers=1, cameras=("ring",),
                       sensors=("phone-lidar",))
    assert len(views) == 3
    for v in views:
        assert v.mask.any() and ((v.depth > 0) | (v.mask == 0)).mean() > 0.9
    twice = compare([WEIGHTS, WEIGHTS], ["ring"], ["phone-lidar"], objects=1,
                    views_per_object=2, cache_dir=tmp_path)
    first, second = twice[("ring", "phone-lidar")]
    assert first == second and 0.0 < first["mean_iou"] <= 1.0
    assert list(tmp_path.glob(f"segment_compare_1_2_ring_phone-lidar_{code_version()}.pkl"))
    compare([WEIGHTS], ["ring"], ["clean"], objects=1, views_per_object=1, cache_dir=tmp_path,
            world="household")  # another world's views are kept under another name
    assert list(tmp_path.glob(f"segment_compare_1_1_ring_clean_household_{code_version()}.pkl"))


def test_missing_or_foreign_weights(tmp_path):
    with pytest.raises(FormatError, match="segmentation weights not found"):
        LearnedSegmenter.load(tmp_path / "none.pt")
    torch.save({"state_dict": {}, "config": "{}"}, tmp_path / "bad.pt")
    with pytest.raises(FormatError, match="bad.pt: not segmentation weights"):
        LearnedSegmenter.load(tmp_path / "bad.pt")


needs_weights = pytest.mark.skipif(not WEIGHTS.is_file(), reason="no shipped weights")


@needs_weights
def test_shipped_weights_record_their_training():
    seg = LearnedSegmenter.load()

    def trainings(record):  # weights between two trainings record both, maybe nested
        mixed = record.get("interpolated")
        return trainings(mixed["old"]) + trainings(mixed["new"]) if mixed else [record]

    for r in trainings(seg.config["training"]):
        assert r["total_seconds"] > 0 and r["validation"]["mean_iou"] > 0.5
    assert WEIGHTS.stat().st_size < 3_000_000


@needs_weights
@pytest.mark.slow
def test_held_out_procedural_captures_are_segmented_by_part():
    """Small held-out objects (2, 3 and 4 parts): every part found, nearly whole. (Large
    ones take longer to segment; docs/evaluation.md has them: 0.95 mean IoU for 6-15
    parts.)"""
    segmenter = LearnedSegmenter.load()
    for k, case in enumerate(procedural_cases(4, seed=7)[:3]):
        # the views the shipped network was trained on (the front arc); on a full ring it
        # splits objects (docs/evaluation.md, issue 20), which a retraining must fix
        capture = render_object(case.obj, base=case.base, views=12, width=192, height=192,
                                seed=k, cameras="front-arc")
        seg = segment(capture, segmenter=segmenter)
        mean, per_part = matched_part_iou(seg.labels, [f.mask for f in capture.frames])
        assert len(case.obj.parts) <= seg.n_parts <= len(case.obj.parts) + 1, case.label
        assert mean > 0.9 and min(per_part.values()) > 0.8, (case.label, per_part)


def test_weights_between_two_networks(tmp_path):
    from pipeline.segment.interpolate import interpolate
    from pipeline.weights import save_weights

    config = {"network": {"dim": 16, "widths": [8, 12, 16, 24, 32], "fine": 0}}
    paths = []
    for seed in (0, 1):
        torch.manual_seed(seed)
        paths.append(save_weights(build_network(16, (8, 12, 16, 24, 32)), config,
                                  tmp_path / f"{seed}.pt"))
    nets = [LearnedSegmenter.load(p).network.state_dict() for p in paths]
    interpolate(paths[0], paths[1], 0.25, tmp_path / "mixed.pt")
    mixed = LearnedSegmenter.load(tmp_path / "mixed.pt")
    assert mixed.config["training"]["interpolated"]["alpha"] == 0.25
    for k, v in mixed.network.state_dict().items():
        if v.is_floating_point():
            assert torch.allclose(v, 0.75 * nets[0][k] + 0.25 * nets[1][k], atol=1e-6)
    other = save_weights(build_network(8, (8, 8, 8, 8, 8)),
                         {"network": {"dim": 8, "widths": [8] * 5, "fine": 0}},
                         tmp_path / "other.pt")
    with pytest.raises(ValueError, match="different networks"):
        interpolate(paths[0], other, 0.5, tmp_path / "x.pt")
