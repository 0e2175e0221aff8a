"""The occupancy network: a convolutional occupancy network on three feature planes.

The paper builds on Convolutional Occupancy Networks (Peng et al. 2020) with a PointNet++
encoder, a 3-D U-Net on a feature grid and an MLP decoder. We keep the structure and take
the paper's cheaper sibling variant, ConvONet's three axis-aligned feature planes with a
2-D U-Net, so training fits in minutes on two CPU cores:

- encoder: a PointNet with local pooling (per-point MLP, features max-pooled per plane cell
  and fed back, as ConvONet's "local pool" encoder does) on the part's points and its
  context (a fourth input channel says which is which);
- the point features averaged into 3 planes (xy, xz, yz) and refined by one shared U-Net;
- decoder: at each query point, the three planes sampled bilinearly and summed, with the
  query's coordinates (Fourier features) and a global code (max-pooled features and the
  frame's metric size) through a residual MLP, to one occupancy logit.
"""

from __future__ import annotations

import torch
from torch import nn
from torch.nn import functional as F

PLANES = ((0, 1), (0, 2), (1, 2))


def _cells(xyz: torch.Tensor, res: int) -> torch.Tensor:
    """Flat cell index (B, 3, N) of every point on every plane; xyz in [-1/2, 1/2]."""
    ij = ((xyz + 0.5) * res).long().clamp(0, res - 1)
    return torch.stack([ij[..., a] * res + ij[..., b] for a, b in PLANES], dim=1)


def _pool_max(feat: torch.Tensor, cells: torch.Tensor, res: int) -> torch.Tensor:
    """Per-point max of the features in the same cell, summed over the planes. (B, N, C)"""
    b, n, c = feat.shape
    out = torch.zeros(b, n, c, dtype=feat.dtype)
    for p in range(3):
        idx = cells[:, p, :, None].expand(-1, -1, c)
        grid = torch.full((b, res * res, c), -1e4, dtype=feat.dtype)
        grid = grid.scatter_reduce(1, idx, feat, reduce="amax", include_self=True)
        out = out + torch.gather(grid, 1, idx)
    return out


def _planes_mean(feat: torch.Tensor, cells: torch.Tensor, res: int) -> torch.Tensor:
    """Features averaged per cell on each plane: (B * 3, C, res, res)."""
    b, n, c = feat.shape
    planes = []
    for p in range(3):
        idx = cells[:, p, :, None].expand(-1, -1, c)
        total = torch.zeros(b, res * res, c, dtype=feat.dtype).scatter_add(1, idx, feat)
        count = torch.zeros(b, res * res, 1, dtype=feat.dtype).scatter_add(
            1, cells[:, p, :, None], torch.ones(b, n, 1, dtype=feat.dtype))
        planes.append((total / count.clamp(min=1)).transpose(1, 2).reshape(b, c, res, res))
    return torch.stack(planes, dim=1).flatten(0, 1)


def sample_planes(planes: torch.Tensor, queries: torch.Tensor) -> torch.Tensor:
    """Plane features (B, 3, C, R, R) read bilinearly at unit ``queries`` (B, Q, 3) and
    summed over the planes: (B, Q, C)."""
    feat = 0
    for p, (a, b) in enumerate(PLANES):
        grid = (2.0 * queries[..., [a, b]])[:, :, None, :]  # to grid_sample's [-1, 1]
        # grid_sample's x indexes the last (column) axis: the plane's second coordinate.
        sampled = F.grid_sample(planes[:, p], grid.flip(-1), mode="bilinear",
                                padding_mode="border", align_corners=False)
        feat = feat + sampled[..., 0].transpose(1, 2)
    return feat


def _conv(cin: int, cout: int, layers: int = 2) -> nn.Sequential:
    mods: list[nn.Module] = []
    for k in range(layers):
        mods += [nn.Conv2d(cin if k == 0 else cout, cout, 3, padding=1), nn.GroupNorm(8, cout),
                 nn.ReLU()]
    return nn.Sequential(*mods)


class UNet2d(nn.Module):
    """A three-level U-Net (res, res/2, res/4); one convolution per side at full resolution,
    where convolutions cost most on the CPU."""

    def __init__(self, c: int):
        super().__init__()
        self.enc1, self.enc2, self.enc3 = _conv(c, c, 1), _conv(c, 2 * c), _conv(2 * c, 2 * c)
        self.dec2, self.dec1 = _conv(4 * c, c), _conv(2 * c, c, 1)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        e1 = self.enc1(x)
        e2 = self.enc2(F.max_pool2d(e1, 2))
        e3 = self.enc3(F.max_pool2d(e2, 2))
        d2 = self.dec2(torch.cat([F.interpolate(e3, scale_factor=2), e2], dim=1))
        return self.dec1(torch.cat([F.interpolate(d2, scale_factor=2), e1], dim=1))


class ResBlock(nn.Module):
    def __init__(self, width: int):
        super().__init__()
        self.fc0, self.fc1 = nn.Linear(width, width), nn.Linear(width, width)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return x + self.fc1(F.relu(self.fc0(F.relu(x))))


class TriplaneOccupancy(nn.Module):
    def __init__(self, channels: int = 32, resolution: int = 32, hidden: int = 64,
                 blocks: int = 3, frequencies: int = 4):
        super().__init__()
        c = channels
        self.res, self.frequencies = resolution, frequencies
        self.point0 = nn.Sequential(nn.Linear(4, 2 * c), nn.ReLU(), nn.Linear(2 * c, c))
        self.point1 = nn.Sequential(nn.ReLU(), nn.Linear(2 * c, 2 * c), nn.ReLU(),
                                    nn.Linear(2 * c, c))
        self.unet = UNet2d(c)
        self.global_code = nn.Sequential(nn.Linear(c + 3, c), nn.ReLU(), nn.Linear(c, c))
        query_dim = 3 + 6 * frequencies
        self.fc_query = nn.Linear(query_dim, hidden)
        self.fc_feat = nn.ModuleList(nn.Linear(2 * c, hidden) for _ in range(blocks))
        self.blocks = nn.ModuleList(ResBlock(hidden) for _ in range(blocks))
        self.out = nn.Linear(hidden, 1)

    def encode(self, points: torch.Tensor, size: torch.Tensor):
        """points (B, N, 4) unit xyz + own-part flag; size (B, 3) log half-sizes."""
        cells = _cells(points[..., :3], self.res)
        f = self.point0(points)
        f = self.point1(torch.cat([f, _pool_max(f, cells, self.res)], dim=-1))
        planes = self.unet(_planes_mean(f, cells, self.res))
        code = self.global_code(torch.cat([f.max(dim=1).values, size], dim=-1))
        return planes.unflatten(0, (-1, 3)), code

    def decode(self, planes: torch.Tensor, code: torch.Tensor,
               queries: torch.Tensor) -> torch.Tensor:
        """Occupancy logits (B, Q) at unit ``queries`` (B, Q, 3)."""
        feat = sample_planes(planes, queries)
        c = torch.cat([feat, code[:, None].expand(-1, queries.shape[1], -1)], dim=-1)
        freq = (2.0 ** torch.arange(self.frequencies, dtype=queries.dtype)) * torch.pi
        angles = (queries[..., None] * freq).flatten(-2)
        x = self.fc_query(torch.cat([queries, torch.sin(angles), torch.cos(angles)], dim=-1))
        for fc, block in zip(self.fc_feat, self.blocks, strict=True):
            x = block(x + fc(c))
        return self.out(F.relu(x))[..., 0]

    def forward(self, points, size, queries):
        planes, code = self.encode(points, size)
        return self.decode(planes, code, queries)


def build_network(**config) -> TriplaneOccupancy:
    return TriplaneOccupancy(**config)
