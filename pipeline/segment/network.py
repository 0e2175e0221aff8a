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
- Point head (optional, ``fine`` > 0; PointRend, Kirillov et al., CVPR 2020): the mask at
  full resolution where it is needed, not on a dense grid. A small convolution over the
  input at ``SIZE`` gives every view fine features once; at any point, a per-point MLP reads
  the coarse logit there, those features and how the point differs from the prompt, and
  gives the final logit. Training samples the points where the coarse mask is least sure
  (and some anywhere); test-time prompting evaluates exactly the points it votes on. The
  half-resolution masks lost most on small parts (validation IoU 0.25 for parts under 100
  grid pixels, 0.88 over 3,000), and drawers of a 12-part cabinet are small.

Sized for 2 shared CPU cores: the stem strides by two at once, so every layer runs at
``SIZE / 2`` or coarser; a training step of 8 images x 24 prompts takes about a second.
"""

from __future__ import annotations

import math

from .features import CHANNELS, SIZE

CENTRE = 3  # embedding channels that hold the part centre (u, v, relative depth)
N_RELATION = 8  # the refinement's inputs: see MaskNet.relation
N_POINT_RELATION = 5  # the point head's: see MaskNet.point_logits


def build_network(dim: int = 32, widths: tuple[int, ...] = (16, 24, 32, 48, 64), fine: int = 0):
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
            self.fine = fine
            if fine:
                self.fine_stem = nn.Sequential(
                    nn.Conv2d(CHANNELS, fine, 3, 1, 1, bias=False), nn.BatchNorm2d(fine),
                    nn.ReLU(True), nn.Conv2d(fine, fine, 3, 1, 1))
                self.point_head = nn.Sequential(
                    nn.Linear(1 + N_POINT_RELATION + fine, 32), nn.ReLU(True),
                    nn.Linear(32, 32), nn.ReLU(True), nn.Linear(32, 1))

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

        def encode_fine(self, x: torch.Tensor) -> torch.Tensor | None:
            """(B, fine, SIZE, SIZE) full-resolution features for the point head (None
            without one)."""
            return self.fine_stem(x) if self.fine else None

        def point_logits(self, coarse: torch.Tensor, fine: torch.Tensor, x: torch.Tensor,
                         uv: torch.Tensor, points: torch.Tensor) -> torch.Tensor:
            """The point head's logits (B, P, N) at ``points`` (B, P, N, 2, model grid
            coordinates) of the masks of prompts ``uv`` (B, P, 2) whose coarse logits are
            ``coarse`` (B, P, h, w)."""
            b, p, n, _ = points.shape
            h = coarse.shape[-1]
            at_coarse = bilinear(coarse.flatten(0, 1)[:, None],
                                 points.flatten(0, 1) * (h / SIZE)).view(b, p, n)
            flat = points.reshape(b, p * n, 2)
            return self.point_head_at(at_coarse, bilinear(fine, flat).view(b, p, n, -1),
                                      bilinear(x[:, :8], flat).view(b, p, n, 8),
                                      bilinear(x[:, :8], uv)[:, :, None], points - uv[:, :, None])

        def point_head_at(self, at_coarse: torch.Tensor, at_fine: torch.Tensor,
                          at_x: torch.Tensor, at_prompt: torch.Tensor, offset: torch.Tensor,
                          ) -> torch.Tensor:
            """The point head on what it reads at each point (any leading shape ``S``): the
            coarse logit (S), the fine features (S, fine), the input's first 8 channels
            there (S, 8) and at the prompt, and the point's offset from the prompt in model
            pixels (S, 2). The head's inputs are the coarse logit, how the point differs
            from the prompt in colour, depth and normal (summed absolute differences), the
            signed offset and the fine features; its output is added to the coarse logit."""
            d = at_x - at_prompt
            head_in = torch.cat([at_coarse[..., None], d[..., 0:3].abs().sum(-1, True),
                                 d[..., 3:4].abs(), d[..., 5:8].abs().sum(-1, True),
                                 offset / SIZE * 2, at_fine], -1)
            return at_coarse + self.point_head(head_in)[..., 0]

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
