"""Joint predictors behind one interface: boxes in, an :class:`ArticulationProgram` out.

- ``geometric``: rules on the boxes alone (no learning), the baseline;
- ``learned``: a small network trained in this repository on procedural objects;
- ``llm``: any local Hugging Face causal LM (or LoRA adapter) prompted with the box text;
- the multi-state estimator (``pipeline.multistate``) when a part is seen at several states.
"""

from __future__ import annotations

from typing import Protocol

from real2code_export.errors import InputError

from ..joint_code import ArticulationProgram
from ..obb import OBB


class JointPredictor(Protocol):
    name: str

    def predict(self, boxes: list[OBB]) -> ArticulationProgram:
        """The articulation of an object whose parts have these boxes (world frame, Z up)."""
        ...


def get_predictor(name: str, **options) -> JointPredictor:
    if name == "geometric":
        from .geometric import GeometricPredictor

        return GeometricPredictor(**options)
    if name == "learned":
        from .learned import LearnedPredictor

        return LearnedPredictor.load(**options)
    if name == "llm":
        from .llm import LLMPredictor

        return LLMPredictor.from_pretrained(**options)
    raise InputError(f"unknown predictor {name!r} (geometric, learned, llm)")
