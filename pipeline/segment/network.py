"""The point-prompted mask network: SAM's split between a heavy image encoder run once per
view and a light prompt decoder run once per query point, at a size that trains on CPUs.

- Encoder: a small U-Net over the view features (``features.py``) giving a
  ``dim``-channel embedding at half resolution, in which pixels of one rigid part should
  look alike and differ from other parts, even from a twin drawer beside them (hence
  the coordinate channels and the image-wide receptive field). Its first three channels
  are trained to hold the centre of the pixel's part (the part's image centroid and mean
  relative depth in this view: a spatial embedding as in Neven et al., CVPR 2019), a dense
  target that teaches the encoder what a rigid part is much faster than the masks alone.
- Decoder: the embedding under the prompt (with a Fourier code of its position) becomes
  a query vector, and the mask logits are its dot product with every pixel's embedding
  (SAM's last step, a hypernetwork token against the upscaled image embedding), refined by
  one small convolution over how each pixel differs from the prompt's (colour, depth,
  normal, position, predicted part centre); a head predicts the mask's IoU (SAM's quality
  score, used to rank masks at test time).

Sized for 2 shared CPU cores: the stem strides by two at once, so every layer runs at
``SIZE / 2`` or coarser; a training step of 8 images x 24 prompts takes about a second.
"""

from __future__ import annotations

import math

from .features import CHANNELS, SIZE

CENTRE = 3  # embedding channels that hold the part centre (u, v, relative depth)
N_RELATION = 8  # the refinement's inputs: see MaskNet.relation


def build_network(dim: int = 32, widths: tuple[int, ...] = (16, 24, 32, 48, 64)):
    import torch
    import torch.nn.functional as F
    from torch import nn

    def block(cin: int, cout: int, stride: int = 1) -> nn.Sequential:
        return nn.Sequential(
            nn.Conv2d(cin, cout, 3, stride, 1, bias=False), nn.BatchNorm2d(cout), nn.ReLU(True),
            nn.Conv2d(cout, cout, 3, 1, 1, bias=False), nn.BatchNorm2d(cout), nn.ReLU(True))

    class MaskNet(nn.Module):
        def __init__(self):
            super().__init__()
            w = widths
            self.stem = block(CHANNELS, w[0], 2)  # SIZE / 2
            self.down = nn.ModuleList(block(w[i], w[i + 1], 2) for i in range(len(w) - 1))
            # up path back to SIZE / 2, with skips
            self.up = nn.ModuleList(block(w[i + 1] + w[i], w[i]) for i in
                                    range(len(w) - 2, -1, -1))
            self.embed = nn.Conv2d(w[0], dim, 1)
            self.n_freq = 4
            self.query = nn.Sequential(nn.Linear(dim + 4 * self.n_freq, 64), nn.ReLU(True),
                                       nn.Linear(64, dim + 1))
            # per prompt, at SIZE / 2: how each pixel relates to the prompted one
            self.refine = nn.Sequential(nn.Conv2d(N_RELATION, 8, 3, 1, 1), nn.ReLU(True),
                                        nn.Conv2d(8, 1, 1))
            self.iou = nn.Sequential(nn.Linear(dim + 2, 64), nn.ReLU(True), nn.Linear(64, 1))
            self.dim = dim

        def encode(self, x: torch.Tensor) -> torch.Tensor:
            """(B, CHANNELS, SIZE, SIZE) -> embedding (B, dim, SIZE/2, SIZE/2)."""
            skips = [self.stem(x)]
            for layer in self.down:
                skips.append(layer(skips[-1]))
            h = skips.pop()
            for layer in self.up:
                skip = skips.pop()
                h = F.interpolate(h, size=skip.shape[-2:], mode="bilinear", align_corners=False)
                h = layer(torch.cat([h, skip], 1))
            return self.embed(h)

        def relation(self, logits: torch.Tensor, embedding: torch.Tensor, x: torch.Tensor,
                     uv: torch.Tensor) -> torch.Tensor:
            """(B, P, N_RELATION, h, w): the coarse logits and how every pixel differs from
            the prompted one in colour, depth, normal (summed absolute differences), image
            position (signed) and predicted part centre (image distance, depth)."""
            h, w = embedding.shape[-2:]
            small = torch.cat([F.avg_pool2d(x[:, :8], 2), embedding[:, :CENTRE]], 1)
            there = bilinear(small, uv * (w / SIZE))[..., None, None]  # (B, P, C, 1, 1)
            d = small[:, None] - there  # (B, P, C, h, w)
            axis = (torch.arange(w, dtype=x.dtype) + 0.5) / w * 2 - 1
            g = uv / SIZE * 2 - 1
            du = (axis[None, None, None, :] - g[..., 0, None, None]).expand_as(logits)
            dv = (axis[None, None, :, None] - g[..., 1, None, None]).expand_as(logits)
            return torch.stack([
                logits, d[:, :, 0:3].abs().sum(2), d[:, :, 3].abs(), d[:, :, 5:8].abs().sum(2),
                du, dv, d[:, :, 8:10].norm(dim=2), d[:, :, 10].abs()], 2)

        def _fourier(self, g: torch.Tensor) -> torch.Tensor:
            freq = (2.0 ** torch.arange(self.n_freq, dtype=g.dtype)) * math.pi
            ang = g[..., None] * freq
            return torch.cat([ang.sin(), ang.cos()], -1).flatten(1)

        def decode(self, embedding: torch.Tensor, x: torch.Tensor, uv: torch.Tensor,
                   ) -> tuple[torch.Tensor, torch.Tensor]:
            """Mask logits (B, P, SIZE/2, SIZE/2) and predicted IoU (B, P) for P prompts per
            image at model grid coordinates ``uv`` (B, P, 2; u right, v down, in [0, SIZE));
            ``x`` is the encoder's input."""
            b, c, h, w = embedding.shape
            p = uv.shape[1]
            at = bilinear(embedding, uv * (w / SIZE))  # (B, P, C)
            g = uv / SIZE * 2 - 1
            out = self.query(torch.cat([at, self._fourier(g.reshape(-1, 2)).view(b, p, -1)], 2))
            q, bias = out[..., :-1], out[..., -1]
            logits = torch.bmm(q, embedding.flatten(2)) / math.sqrt(self.dim) + bias[..., None]
            logits = logits.view(b, p, h, w)
            refine_in = self.relation(logits, embedding, x, uv).flatten(0, 1)
            logits = logits + self.refine(refine_in).view(b, p, h, w)
            prob = torch.sigmoid(logits.detach())
            stats = torch.stack([prob.mean((2, 3)), (prob > 0.5).float().mean((2, 3))], 2)
            iou = self.iou(torch.cat([q, stats], 2))[..., 0]
            return logits, iou

    return MaskNet()


def bilinear(grid, uv):
    """Values of ``grid`` (B, C, H, W) at continuous pixel coordinates ``uv`` (B, P, 2;
    pixel k spans [k, k + 1)), by gathering the four neighbours (not grid_sample over a
    per-prompt copy of the embedding, whose backward pass dominated a training step)."""
    import torch

    b, c, h, w = grid.shape
    x = (uv[..., 0] - 0.5).clamp(0, w - 1)
    y = (uv[..., 1] - 0.5).clamp(0, h - 1)
    x0, y0 = x.floor().long().clamp(max=w - 2), y.floor().long().clamp(max=h - 2)
    fx, fy = (x - x0)[..., None], (y - y0)[..., None]
    flat = grid.flatten(2).transpose(1, 2)  # (B, H*W, C)

    def at(yy, xx):
        idx = (yy * w + xx)[..., None].expand(-1, -1, c)
        return torch.gather(flat, 1, idx)

    return ((1 - fy) * ((1 - fx) * at(y0, x0) + fx * at(y0, x0 + 1))
            + fy * ((1 - fx) * at(y0 + 1, x0) + fx * at(y0 + 1, x0 + 1)))
