"""The mask network trained in this repository (``python -m pipeline.segment.train``),
behind the promptable-segmenter interface of :mod:`pipeline.segment.prompting`."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from .features import SIZE, frame_features, to_model_uv
from .train import WEIGHTS

STABILITY_OFFSET = 1.0  # SAM's: how far the logit threshold moves for the stability score


class LearnedSegmenter:
    name = "learned"

    def __init__(self, network, config: dict):
        self.network = network.eval()
        self.config = config
        self._embeddings = None
        self._shapes: list[tuple[int, int]] = []

    @classmethod
    def load(cls, path: str | Path | None = None) -> LearnedSegmenter:
        import torch

        from real2code_export.errors import FormatError

        from .network import build_network

        path = Path(path) if path is not None else WEIGHTS
        if not path.is_file():
            raise FormatError(path, None, "segmentation weights not found (train them with "
                              "`python -m pipeline.segment.train`)")
        try:
            blob = torch.load(path, map_location="cpu", weights_only=True)
            config = json.loads(blob["config"])
            net_cfg = config["network"]
            network = build_network(net_cfg["dim"], tuple(net_cfg["widths"]))
            network.load_state_dict(blob["state_dict"])
        except (KeyError, RuntimeError, ValueError) as e:
            raise FormatError(path, None, f"not mask-network weights: {e}") from e
        return cls(network, config)

    def set_views(self, frames) -> None:
        """Encode every view once (the heavy half of the network)."""
        import torch

        self._inputs = torch.from_numpy(np.stack([frame_features(f) for f in frames]))
        with torch.no_grad():
            self._embeddings = torch.cat([self.network.encode(self._inputs[s:s + 8])
                                          for s in range(0, len(self._inputs), 8)])
        self._shapes = [f.depth.shape for f in frames]

    def predict(self, view: int, prompts_uv: np.ndarray, query_uv: np.ndarray,
                ) -> tuple[np.ndarray, np.ndarray]:
        """For each prompt (capture pixel coordinates u, v) the probability that each query
        pixel lies on the prompted part (K, N), and each mask's quality (K,): the predicted
        IoU times SAM's stability score."""
        import torch

        from .network import bilinear

        if self._embeddings is None:
            raise RuntimeError("call set_views first")
        h, w = self._shapes[view]
        emb = self._embeddings[view:view + 1]
        scale = emb.shape[-1] / SIZE
        prompts = torch.from_numpy(to_model_uv(prompts_uv, h, w)).float()
        query = torch.from_numpy(to_model_uv(query_uv, h, w) * scale).float()
        probs, quality = [], []
        with torch.no_grad():
            for s in range(0, len(prompts), 64):
                logits, iou = self.network.decode(emb, self._inputs[view:view + 1],
                                                  prompts[None, s:s + 64])
                at = bilinear(logits, query[None])[0].T  # (K, N)
                probs.append(torch.sigmoid(at).numpy())
                hi = (logits > STABILITY_OFFSET).sum((2, 3)).float()
                lo = (logits > -STABILITY_OFFSET).sum((2, 3)).float().clamp(min=1)
                quality.append((iou.clamp(0, 1) * hi / lo)[0].numpy())
        if not probs:
            return np.zeros((0, len(query_uv))), np.zeros(0)
        return np.concatenate(probs), np.concatenate(quality)
