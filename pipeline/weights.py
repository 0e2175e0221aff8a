"""A learned model's weights file, saved and loaded the same way for every network (the joint
predictor, the mask network, the occupancy network), failing the same way.

A weights file is ``torch.save({"config": JSON text with a "network" entry, "state_dict":
...})``, written atomically so an interrupted training run never leaves a truncated weights
file in the package. A missing file, a file that is not a checkpoint and a checkpoint of
another network are each a :class:`WeightsError` naming the file.
"""

from __future__ import annotations

import io
import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

from real2code_export.atomic import write_bytes
from real2code_export.errors import FormatError


class WeightsError(FormatError):
    """A weights file that is missing or is not this network's."""


def save_weights(net, config: dict, path: str | Path) -> Path:
    import torch

    buffer = io.BytesIO()
    torch.save({"state_dict": net.state_dict(), "config": json.dumps(config)}, buffer)
    return write_bytes(path, buffer.getvalue())


def load_network(path: str | Path, what: str, build: Callable[[dict], Any],
                 train_command: str) -> tuple[Any, dict]:
    """The network ``build(config["network"])`` with the weights in ``path`` (in eval mode)
    and the file's whole config. ``what`` names the network in messages."""
    import pickle

    import torch

    path = Path(path)
    if not path.is_file():
        raise WeightsError(path, None, f"{what} weights not found (train them: "
                           f"{train_command})")
    try:
        blob = torch.load(path, map_location="cpu", weights_only=True)
        config = json.loads(blob["config"])
        network = build(config["network"])
        network.load_state_dict(blob["state_dict"])
    except (OSError, RuntimeError, KeyError, ValueError, TypeError, EOFError,
            pickle.UnpicklingError) as e:
        raise WeightsError(path, None, f"not {what} weights ({type(e).__name__}: {e})") from e
    network.eval()
    return network, config
