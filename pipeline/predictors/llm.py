"""The code-LLM backend: any local Hugging Face causal LM (or a LoRA adapter on one),
prompted with the box text, its completion parsed by the same parser as every predictor.

This is how the paper runs its fine-tuned CodeLlama. Nothing is downloaded: the model and
its tokenizer are read from a local folder (``from_pretrained(path)``), as are adapters.
The completion is parsed with :func:`pipeline.joint_code.parse_program` (``ast``, never
executed); malformed output raises :class:`CodeFormatError` naming the line.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from real2code_export.errors import Real2CodeError

from ..joint_code import ArticulationProgram, CodeFormatError, format_boxes, parse_program
from ..obb import OBB

PROMPT_SUFFIX = "\n# articulation\n"


def build_prompt(boxes: list[OBB]) -> str:
    """The text the model continues: the boxes, then a marker after which it writes
    ``root_geom = ...`` and ``child_joints = [...]``."""
    return format_boxes(boxes) + PROMPT_SUFFIX


def completion_code(text: str) -> str:
    """The program part of a completion: from ``root_geom`` to the closing bracket of
    ``child_joints`` (models often keep talking after it)."""
    start = text.find("root_geom")
    if start < 0:
        raise CodeFormatError(None, "model output has no `root_geom = ...`: "
                              f"{text[:80]!r}")
    text = text[start:]
    head = text.find("child_joints")
    if head < 0:
        return text
    depth, opened = 0, False
    for i in range(head, len(text)):
        if text[i] == "[":
            depth, opened = depth + 1, True
        elif text[i] == "]":
            depth -= 1
            if opened and depth == 0:
                return text[: i + 1]
    return text  # unterminated: the parser names the line


@dataclass
class LLMPredictor:
    model: object
    tokenizer: object
    max_new_tokens: int = 768
    name: str = "llm"

    @classmethod
    def from_pretrained(cls, path: str | Path, adapter: str | Path | None = None,
                        max_new_tokens: int = 768) -> LLMPredictor:
        """Load a local causal LM (a folder with config, weights and tokenizer) and, if
        given, a LoRA adapter folder on top of it."""
        try:
            from transformers import AutoModelForCausalLM, AutoTokenizer
        except ImportError as e:
            raise Real2CodeError("the LLM predictor needs `transformers` "
                                 "(pip install -e '.[llm]')") from e
        path = Path(path)
        if not (path / "config.json").is_file():
            raise Real2CodeError(f"{path}: not a Hugging Face model folder (no config.json)")
        tokenizer = AutoTokenizer.from_pretrained(path, local_files_only=True)
        model = AutoModelForCausalLM.from_pretrained(path, local_files_only=True)
        if adapter is not None:
            adapter = Path(adapter)
            if not (adapter / "adapter_config.json").is_file():
                raise Real2CodeError(f"{adapter}: not a PEFT adapter folder "
                                     "(no adapter_config.json)")
            from peft import PeftModel

            model = PeftModel.from_pretrained(model, adapter, local_files_only=True)
        model.eval()
        return cls(model, tokenizer, max_new_tokens)

    def complete(self, prompt: str) -> str:
        import torch

        inputs = self.tokenizer(prompt, return_tensors="pt")
        with torch.no_grad():
            out = self.model.generate(
                **inputs, max_new_tokens=self.max_new_tokens, do_sample=False,
                pad_token_id=self.tokenizer.pad_token_id or self.tokenizer.eos_token_id)
        new = out[0, inputs["input_ids"].shape[1]:]
        return self.tokenizer.decode(new, skip_special_tokens=True)

    def predict(self, boxes: list[OBB]) -> ArticulationProgram:
        return parse_program(completion_code(self.complete(build_prompt(boxes))), len(boxes))
