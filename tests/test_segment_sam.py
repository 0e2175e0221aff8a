"""The Segment Anything backend on a tiny, randomly initialised SAM (no checkpoint is
downloaded): prompts and mask reads land where SAM's own pre- and post-processing put
them, and the backend runs through the paper's test-time prompting."""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest

torch = pytest.importorskip("torch")
if importlib.util.find_spec("segment_anything") is None:  # its import needs torchvision
    pytest.skip("segment-anything is not installed", allow_module_level=True)

from pipeline.procedural import generate  # noqa: E402
from pipeline.render import render_object  # noqa: E402
from pipeline.segment import get_segmenter, segment  # noqa: E402
from pipeline.segment.prompting import PromptingOptions  # noqa: E402
from pipeline.segment.sam import SamSegmenter, resized_shape, tiny_sam  # noqa: E402
from real2code_export.errors import FormatError, Real2CodeError  # noqa: E402


@pytest.fixture(scope="module")
def capture():
    return render_object(generate("box", 2, 0), views=3, width=48, height=40, seed=0)


def test_masks_read_at_query_pixels_match_sams_postprocessing(capture):
    sam = tiny_sam(seed=1)
    backend = SamSegmenter(sam)
    backend.set_views(capture.frames)
    prompts = np.array([[10.5, 20.5], [30.25, 12.75], [2.5, 37.5]])
    h, w = capture.frames[0].depth.shape
    rows, cols = np.mgrid[0:h, 0:w]
    query = np.stack([cols.ravel() + 0.5, rows.ravel() + 0.5], 1)
    probs, quality = backend.predict(0, prompts, query)
    assert probs.shape == (3, h * w) and quality.shape == (3,)
    assert ((quality >= 0) & (quality <= 1)).all()
    # The reference: SamPredictor's steps by hand, full-size masks from postprocess_masks.
    nh, nw = resized_shape(h, w, sam.image_encoder.img_size)
    coords = torch.tensor(prompts * [nw / w, nh / h] - 0.5, dtype=torch.float)[:, None]
    with torch.no_grad():
        sparse, dense = sam.prompt_encoder(points=(coords, torch.ones(3, 1, dtype=torch.int)),
                                           boxes=None, masks=None)
        low, iou = sam.mask_decoder(image_embeddings=backend._features[0],
                                    image_pe=sam.prompt_encoder.get_dense_pe(),
                                    sparse_prompt_embeddings=sparse,
                                    dense_prompt_embeddings=dense, multimask_output=True)
        full = sam.postprocess_masks(low, (nh, nw), (h, w))
    best = iou.argmax(1)
    reference = torch.sigmoid(full[torch.arange(3), best]).numpy().reshape(3, -1)
    assert np.abs(reference - probs).max() < 0.02  # bilinear once vs twice
    assert np.corrcoef(reference.ravel(), probs.ravel())[0, 1] > 0.99


def test_prompting_runs_with_a_sam(capture):
    seg = segment(capture, segmenter=SamSegmenter(tiny_sam(seed=2)),
                  options=PromptingOptions(prompts=8, min_quality=0.0, min_prompts=1))
    assert seg.method == "sam" and len(seg.labels) == len(capture.frames)
    for lab, frame in zip(seg.labels, capture.frames, strict=True):
        assert lab.shape == frame.depth.shape
        assert np.array_equal(lab > 0, frame.depth > 0)


def test_checkpoint_errors(tmp_path):
    with pytest.raises(Real2CodeError, match="needs a checkpoint"):
        get_segmenter("sam")
    with pytest.raises(FormatError, match="SAM checkpoint not found"):
        SamSegmenter.load(tmp_path / "missing.pth")
    with pytest.raises(FormatError, match="unknown SAM model type 'vit_x'"):
        SamSegmenter.load(tmp_path / "missing.pth", "vit_x")
    bad = tmp_path / "tiny.pth"
    torch.save(tiny_sam().state_dict(), bad)
    with pytest.raises(FormatError, match=r"tiny.pth: not a vit_b SAM checkpoint"):
        SamSegmenter.load(bad, "vit_b")
