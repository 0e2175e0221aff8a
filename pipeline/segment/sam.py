"""A Segment Anything backend, for users with a SAM checkpoint fine-tuned the paper's way
(one point in, the kinematic part's mask out): ``segment-anything`` 1.0, checkpoint by path.

Prompting follows ``SamPredictor`` (resize the longest side to the encoder's size, SAM's
own normalisation and padding, one positive point per prompt, three candidate masks of
which the one with the highest predicted IoU is kept) but reads each mask at the query
pixels straight from the low-resolution logits instead of upsampling every mask to the
full image.
"""

from __future__ import annotations

import importlib
import importlib.util
import sys
from pathlib import Path

import numpy as np

MODEL_TYPES = ("vit_b", "vit_l", "vit_h")
STABILITY_OFFSET = 1.0  # SamAutomaticMaskGenerator's default


def sam_modules():
    """``segment_anything.modeling``, ``.build_sam`` and ``.utils.amg``.

    The package's ``__init__`` also imports ``SamPredictor``, whose image resizing needs
    torchvision; the model does not. Where torchvision is missing (no CPU build matching
    the installed torch, as on our machines), the subpackages are loaded without that
    ``__init__``."""
    try:
        importlib.import_module("segment_anything")
    except ModuleNotFoundError as e:
        if e.name != "torchvision":
            raise
        spec = importlib.util.find_spec("segment_anything")
        sys.modules["segment_anything"] = importlib.util.module_from_spec(spec)
    return (importlib.import_module("segment_anything.modeling"),
            importlib.import_module("segment_anything.build_sam"),
            importlib.import_module("segment_anything.utils.amg"))


def tiny_sam(seed: int = 0, img_size: int = 64, dim: int = 32):
    """A randomly initialised Sam with SAM's architecture at toy size (tests, no download)."""
    from functools import partial

    import torch

    modeling, _, _ = sam_modules()
    torch.manual_seed(seed)
    patch = 8
    return modeling.Sam(
        image_encoder=modeling.ImageEncoderViT(
            img_size=img_size, patch_size=patch, embed_dim=dim, depth=1, num_heads=2,
            mlp_ratio=2.0, out_chans=dim, qkv_bias=True,
            norm_layer=partial(torch.nn.LayerNorm, eps=1e-6), use_rel_pos=True,
            window_size=4, global_attn_indexes=(0,)),
        prompt_encoder=modeling.PromptEncoder(
            embed_dim=dim, image_embedding_size=(img_size // patch, img_size // patch),
            input_image_size=(img_size, img_size), mask_in_chans=4),
        mask_decoder=modeling.MaskDecoder(
            num_multimask_outputs=3, transformer=modeling.TwoWayTransformer(
                depth=1, embedding_dim=dim, mlp_dim=2 * dim, num_heads=2),
            transformer_dim=dim, iou_head_depth=2, iou_head_hidden_dim=16),
        pixel_mean=[123.675, 116.28, 103.53], pixel_std=[58.395, 57.12, 57.375]).eval()


def resized_shape(height: int, width: int, long_side: int) -> tuple[int, int]:
    """SAM's ``ResizeLongestSide.get_preprocess_shape``."""
    scale = long_side / max(height, width)
    return int(height * scale + 0.5), int(width * scale + 0.5)


class SamSegmenter:
    name = "sam"

    def __init__(self, sam):
        self.sam = sam.eval()
        self._features = []
        self._sizes: list[tuple[tuple[int, int], tuple[int, int]]] = []

    @classmethod
    def load(cls, checkpoint: str | Path, model_type: str = "vit_b") -> SamSegmenter:
        from real2code_export.errors import FormatError

        checkpoint = Path(checkpoint)
        if model_type not in MODEL_TYPES:
            raise FormatError(checkpoint, None, f"unknown SAM model type {model_type!r}; "
                              f"choose from {list(MODEL_TYPES)}")
        if not checkpoint.is_file():
            raise FormatError(checkpoint, None, "SAM checkpoint not found")
        _, build, _ = sam_modules()
        try:
            sam = build.sam_model_registry[model_type](checkpoint=str(checkpoint))
        except (RuntimeError, KeyError, ValueError, OSError) as e:
            raise FormatError(checkpoint, None, f"not a {model_type} SAM checkpoint: {e}") from e
        return cls(sam)

    def set_views(self, frames) -> None:
        import torch
        from PIL import Image

        long_side = self.sam.image_encoder.img_size
        self._features, self._sizes = [], []
        with torch.no_grad():
            for frame in frames:
                h, w = frame.rgb.shape[:2]
                nh, nw = resized_shape(h, w, long_side)
                image = np.array(Image.fromarray(frame.rgb).resize(
                    (nw, nh), Image.Resampling.BILINEAR))
                x = torch.as_tensor(image).permute(2, 0, 1)[None].float()
                self._features.append(self.sam.image_encoder(self.sam.preprocess(x)))
                self._sizes.append(((h, w), (nh, nw)))

    def predict(self, view: int, prompts_uv: np.ndarray, query_uv: np.ndarray,
                ) -> tuple[np.ndarray, np.ndarray]:
        import torch

        from .network import bilinear

        _, _, amg = sam_modules()
        (h, w), (nh, nw) = self._sizes[view]
        scale = np.array([nw / w, nh / h])
        long_side = self.sam.image_encoder.img_size
        probs, quality = [], []
        with torch.no_grad():
            for s in range(0, len(prompts_uv), 64):
                # SAM's point coordinates are pixel indices (it adds 0.5 for the centre).
                pts = torch.as_tensor(prompts_uv[s:s + 64] * scale - 0.5,
                                      dtype=torch.float)[:, None]
                sparse, dense = self.sam.prompt_encoder(
                    points=(pts, torch.ones(pts.shape[:2], dtype=torch.int)), boxes=None,
                    masks=None)
                low, iou = self.sam.mask_decoder(
                    image_embeddings=self._features[view],
                    image_pe=self.sam.prompt_encoder.get_dense_pe(),
                    sparse_prompt_embeddings=sparse, dense_prompt_embeddings=dense,
                    multimask_output=True)
                best = iou.argmax(1)
                rows = torch.arange(len(best))
                logits, iou = low[rows, best], iou[rows, best]  # (K, r, r), (K,)
                r = logits.shape[-1] / long_side  # low-res pixels per resized pixel
                query = torch.as_tensor(query_uv * scale * r, dtype=torch.float)[None]
                probs.append(torch.sigmoid(bilinear(logits[None], query)[0].T).numpy())
                stability = amg.calculate_stability_score(logits, self.sam.mask_threshold,
                                                          STABILITY_OFFSET)
                quality.append((iou.clamp(0, 1) * stability).numpy())
        if not probs:
            return np.zeros((0, len(query_uv))), np.zeros(0)
        return np.concatenate(probs), np.concatenate(quality)
