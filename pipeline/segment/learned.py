"""The mask network trained in this repository (``python -m pipeline.segment.train``),
behind the promptable-segmenter interface of :mod:`pipeline.segment.prompting`."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .features import SIZE, frame_features, object_window, upright_angles, whole_view

STABILITY_OFFSET = 1.0  # SAM's: how far the logit threshold moves for the stability score
# The point head refines only the points whose coarse logit is this unsure (PointRend's
# inference refines only uncertain points too): beyond it the head changes almost nothing
# (on 24 views of 6 dev captures it turned 0.014 % of those points to the other side, 0.08 %
# beyond 4) while they are most of the points (87 % of them beyond 6).
POINT_HEAD_MARGIN = 6.0
WEIGHTS = Path(__file__).resolve().parent / "weights" / "segmenter.pt"  # the shipped weights


class LearnedSegmenter:
    name = "learned"

    def __init__(self, network, config: dict, window: str | None = None):
        self.network = network.eval()
        self.config = config
        # what the grid covers: the object's square ("object") or the whole view ("view",
        # the first shipped weights were trained so); the weights record theirs
        self.window = window or config.get("input", {}).get("window", "view")
        self._inputs = self._embeddings = None  # set_views: per view, the network input,
        self._windows, self._fine = [], []  # its embedding, window and fine features

    @classmethod
    def load(cls, path: str | Path | None = None) -> LearnedSegmenter:
        from ..weights import load_network
        from .network import build_network

        network, config = load_network(
            WEIGHTS if path is None else path, "segmentation",
            lambda c: build_network(c["dim"], tuple(c["widths"]), c.get("fine", 0)),
            "python -m pipeline.segment.train")
        return cls(network, config)

    def set_views(self, frames) -> None:
        """Encode every view once (the heavy half of the network)."""
        import torch

        # a rolled view's window is turned upright, as the training views stood
        self._windows = [object_window(f.depth, angle=a) if self.window == "object"
                         else whole_view(*f.depth.shape)
                         for f, a in zip(frames, upright_angles(frames), strict=True)]
        self._inputs = torch.from_numpy(np.stack([frame_features(f, w) for f, w in
                                                  zip(frames, self._windows, strict=True)]))
        with torch.no_grad():
            self._embeddings = torch.cat([self.network.encode(self._inputs[s:s + 8])
                                          for s in range(0, len(self._inputs), 8)])
            self._fine = [self.network.encode_fine(self._inputs[v:v + 1])
                          for v in range(len(self._inputs))]

    def predict(self, view: int, prompts_uv: np.ndarray, query_uv: np.ndarray,
                ) -> tuple[np.ndarray, np.ndarray]:
        """For each prompt (capture pixel coordinates u, v) the probability that each query
        pixel lies on the prompted part (K, N), and each mask's quality (K,): the predicted
        IoU times SAM's stability score."""
        import torch

        from .network import bilinear

        if self._embeddings is None:
            raise RuntimeError("call set_views first")
        window = self._windows[view]
        emb, x = self._embeddings[view:view + 1], self._inputs[view:view + 1]
        fine = self._fine[view]
        prompts = torch.from_numpy(window.to_model(prompts_uv)).float()
        query = torch.from_numpy(window.to_model(query_uv)).float()  # model grid coordinates
        probs, quality = [], []
        net = self.network
        with torch.no_grad():
            if net.fine:  # what the point head reads at the query points, once per view
                at_fine = bilinear(fine, query[None])[0]
                at_x = bilinear(x[:, :8], query[None])[0]
            for s in range(0, len(prompts), 64):
                uv = prompts[None, s:s + 64]
                logits, iou = net.decode(emb, x, uv)
                at = bilinear(logits[0][:, None], query[None].expand(uv.shape[1], -1, -1)
                              * (logits.shape[-1] / SIZE))[..., 0]  # (K, N) coarse
                if net.fine:
                    k, n = torch.nonzero(at.abs() < POINT_HEAD_MARGIN, as_tuple=True)
                    at_prompt = bilinear(x[:, :8], uv)[0]
                    at[k, n] = net.point_head_at(at[k, n], at_fine[n], at_x[n], at_prompt[k],
                                                 query[n] - uv[0, k])
                probs.append(torch.sigmoid(at).numpy())
                hi = (logits > STABILITY_OFFSET).sum((2, 3)).float()
                lo = (logits > -STABILITY_OFFSET).sum((2, 3)).float().clamp(min=1)
                quality.append((iou.clamp(0, 1) * hi / lo)[0].numpy())
        if not probs:
            return np.zeros((0, len(query_uv))), np.zeros(0)
        return np.concatenate(probs), np.concatenate(quality)
