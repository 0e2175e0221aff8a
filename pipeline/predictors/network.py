"""The learned joint predictor's network: a small set transformer over box tokens (one token
per part's box, :mod:`.features`), with a head per field of a child joint and a pointer over
the other boxes for the parent."""

from __future__ import annotations

from .features import EDGES, N_FEATURES

JOINT_TYPES = ("hinge", "slide")


def build_network(d_model: int = 96, layers: int = 3, heads: int = 4):
    import torch
    from torch import nn

    class BoxSetNet(nn.Module):
        def __init__(self):
            super().__init__()
            self.embed = nn.Sequential(nn.Linear(N_FEATURES, d_model), nn.GELU(),
                                       nn.Linear(d_model, d_model))
            layer = nn.TransformerEncoderLayer(d_model, heads, 2 * d_model, dropout=0.0,
                                               batch_first=True, norm_first=True)
            self.encoder = nn.TransformerEncoder(layer, layers, enable_nested_tensor=False)
            self.root = nn.Linear(d_model, 1)
            self.joint_type = nn.Linear(d_model, len(JOINT_TYPES))  # not .type: nn.Module has one
            self.idx = nn.Linear(d_model, 3)
            self.edge = nn.Linear(d_model, 3 * len(EDGES))  # the edge given each axis
            self.sign = nn.Linear(d_model, 3 * 2)  # the sign given each axis
            self.query = nn.Linear(d_model, d_model)
            self.key = nn.Linear(d_model, d_model)

        def forward(self, x: torch.Tensor, pad: torch.Tensor) -> dict[str, torch.Tensor]:
            h = self.encoder(self.embed(x), src_key_padding_mask=pad)
            b, n, _ = h.shape
            parent = (self.query(h) @ self.key(h).transpose(1, 2)) / d_model**0.5
            parent = parent.masked_fill(pad[:, None, :], -1e9)
            eye = torch.eye(n, dtype=torch.bool, device=h.device)[None]
            parent = parent.masked_fill(eye, -1e9)  # a box is not its own parent
            return {
                "root": self.root(h).squeeze(-1).masked_fill(pad, -1e9),
                "type": self.joint_type(h),
                "idx": self.idx(h),
                "edge": self.edge(h).view(b, n, 3, len(EDGES)),
                "sign": self.sign(h).view(b, n, 3, 2),
                "parent": parent,
            }

    return BoxSetNet()
