"""The mask network chosen by the capture's measured depth noise: the depth cleanup's own test
decides (one threshold), a forced choice overrides it, a bad weights file is refused naming
it, and the two shipped networks load as one architecture."""

from __future__ import annotations

import json

import numpy as np
import pytest

torch = pytest.importorskip("torch")

from pipeline.depth_cleanup import (  # noqa: E402
    CleanupOptions,
    clean_capture,
    is_noisy,
    measured_noisy,
)
from pipeline.procedural import generate  # noqa: E402
from pipeline.render import render_object  # noqa: E402
from pipeline.segment import choose as chooser  # noqa: E402
from pipeline.segment.choose import NOISY_WEIGHTS, MaskWeights, choose  # noqa: E402
from pipeline.segment.learned import WEIGHTS  # noqa: E402
from pipeline.sensors import PRESETS, degrade  # noqa: E402
from pipeline.weights import WeightsError  # noqa: E402

needs_both = pytest.mark.skipif(not (WEIGHTS.is_file() and NOISY_WEIGHTS.is_file()),
                                reason="no shipped mask weights")


@pytest.fixture(scope="module")
def summaries():
    """The depth cleanup's summaries of one small capture, exact and through phone LiDAR."""
    capture = render_object(generate("box", 2, 0), views=3, width=64, height=64, seed=0)
    noisy = degrade(capture, PRESETS["phone-lidar"], seed=1)
    return clean_capture(capture)[1], clean_capture(noisy)[1]


def test_the_cleanup_s_threshold_is_the_one_test():
    threshold = CleanupOptions().min_noise_rel
    assert is_noisy(threshold) and not is_noisy(np.nextafter(threshold, 0))
    exact, noisy = ({"noise_rel": [0.0], "noisy": v, "min_noise_rel": threshold}
                    for v in (False, True))
    # a summary saved before the verdict was kept: judged by the same test
    assert measured_noisy({"noise_rel": [0.0, threshold]})
    assert not measured_noisy({"noise_rel": [float(np.nextafter(threshold, 0))]})
    assert choose("auto", {"noise_rel": [threshold]}).used == "noisy"
    # the chooser reads the cleanup's verdict, not a threshold of its own
    assert choose("auto", exact).used == "clean" and choose("auto", noisy).used == "noisy"


def test_auto_picks_by_the_measured_noise(summaries):
    exact, noisy = summaries
    assert not measured_noisy(exact) and max(exact["noise_rel"]) < exact["min_noise_rel"]
    assert measured_noisy(noisy) and max(noisy["noise_rel"]) >= noisy["min_noise_rel"]
    picked = choose("auto", exact), choose("auto", noisy)
    assert [c.used for c in picked] == ["clean", "noisy"]
    assert [c.weights for c in picked] == [WEIGHTS, NOISY_WEIGHTS]
    assert "below" in picked[0].why and "at or above" in picked[1].why
    assert picked[1].noise_rel == max(noisy["noise_rel"])
    json.dumps(picked[1].record())  # goes into report.json and the model's metadata


def test_a_forced_choice_overrides_the_noise(summaries, tmp_path):
    exact, noisy = summaries
    assert choose("clean", noisy).weights == WEIGHTS
    assert choose("noisy", exact).weights == NOISY_WEIGHTS
    mine = tmp_path / "mine.pt"
    for summary in summaries:
        c = choose(str(mine), summary)
        assert (c.weights, c.used, c.mode) == (mine, "mine.pt", str(mine))
        assert "forced" in c.why


def test_a_missing_or_foreign_weights_file_is_named(tmp_path, monkeypatch):
    with pytest.raises(WeightsError, match="none.pt"):
        MaskWeights(tmp_path / "none.pt")
    torch.save({"state_dict": {}, "config": "{}"}, tmp_path / "bad.pt")
    with pytest.raises(WeightsError, match="bad.pt: not segmentation weights"):
        MaskWeights(str(tmp_path / "bad.pt"))
    # auto loads both shipped networks up front: a missing one fails before any work
    monkeypatch.setitem(chooser.SHIPPED, "noisy", tmp_path / "segmenter_noisy.pt")
    with pytest.raises(WeightsError, match="segmenter_noisy.pt"):
        MaskWeights("auto")
    MaskWeights("clean")  # a forced choice loads only its own


@needs_both
def test_both_shipped_networks_load_as_one_architecture(summaries):
    weights = MaskWeights("auto")
    (clean, c1), (noisy, c2) = (weights.for_capture(s) for s in summaries)
    assert (c1.used, c2.used) == ("clean", "noisy") and clean is not noisy
    assert clean.config["network"] == noisy.config["network"]
    a, b = clean.network.state_dict(), noisy.network.state_dict()
    assert a.keys() == b.keys() and all(a[k].shape == b[k].shape for k in a)
    assert any(not torch.equal(a[k], b[k]) for k in a)  # two trainings, not one file twice
    for path in (WEIGHTS, NOISY_WEIGHTS):
        assert path.stat().st_size < 3_000_000
    assert noisy.config["training"]  # its training record travels with it


def test_the_package_ships_both_files():
    import tomllib
    from fnmatch import fnmatch
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    globs = tomllib.loads((root / "pyproject.toml").read_text())["tool"]["setuptools"][
        "package-data"]["pipeline"]
    for path in (WEIGHTS, NOISY_WEIGHTS):
        inside = path.relative_to(root / "pipeline").as_posix()
        assert any(fnmatch(inside, g) for g in globs), inside
