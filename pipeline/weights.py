"""Saving the learned models' weights: one file per model, the state dict and the config
that rebuilds the network (JSON), written atomically so an interrupted training run never
leaves a truncated weights file in the package."""

from __future__ import annotations

import io
import json
from pathlib import Path

from real2code_export.atomic import write_bytes


def save_weights(net, config: dict, path: str | Path) -> Path:
    import torch

    buffer = io.BytesIO()
    torch.save({"state_dict": net.state_dict(), "config": json.dumps(config)}, buffer)
    return write_bytes(path, buffer.getvalue())
