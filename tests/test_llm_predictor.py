"""The code-LLM backend's plumbing on a tiny model built from a config (nothing downloaded):
loading a local folder and a LoRA adapter, prompting, generating, parsing, error paths."""

from __future__ import annotations

import numpy as np
import pytest

transformers = pytest.importorskip("transformers")
torch = pytest.importorskip("torch")

from pipeline.joint_code import (  # noqa: E402
    ArticulationProgram,
    ChildJoint,
    CodeFormatError,
    format_program,
)
from pipeline.obb import OBB  # noqa: E402
from pipeline.predictors import get_predictor  # noqa: E402
from pipeline.predictors.llm import LLMPredictor, build_prompt, completion_code  # noqa: E402
from real2code_export.errors import Real2CodeError  # noqa: E402

BOXES = [OBB(np.array([0.0, 0.0, 0.4]), np.eye(3), np.array([0.3, 0.25, 0.4])),
         OBB(np.array([0.31, -0.1, 0.4]), np.eye(3), np.array([0.01, 0.12, 0.35]))]
PROGRAM = ArticulationProgram(0, (ChildJoint(1, "hinge", 2, (-1, 1), 1),))


def _char_tokenizer(text: str):
    """A character-level tokenizer made here (no download)."""
    from tokenizers import Regex, Tokenizer, decoders, models, pre_tokenizers
    from transformers import PreTrainedTokenizerFast

    vocab = {"<unk>": 0, "<eos>": 1}
    for ch in sorted(set(text)):
        vocab.setdefault(ch, len(vocab))
    tok = Tokenizer(models.WordLevel(vocab, unk_token="<unk>"))
    tok.pre_tokenizer = pre_tokenizers.Split(Regex("."), behavior="isolated")
    tok.decoder = decoders.Fuse()
    return PreTrainedTokenizerFast(tokenizer_object=tok, unk_token="<unk>", eos_token="<eos>",
                                   pad_token="<eos>")


def _tiny_model(vocab_size: int):
    from transformers import LlamaConfig, LlamaForCausalLM

    torch.manual_seed(0)
    config = LlamaConfig(vocab_size=vocab_size, hidden_size=48, intermediate_size=96,
                         num_hidden_layers=2, num_attention_heads=4, num_key_value_heads=4,
                         max_position_embeddings=1024, eos_token_id=1, pad_token_id=1,
                         bos_token_id=1)
    return LlamaForCausalLM(config)


@pytest.fixture(scope="module")
def folders(tmp_path_factory):
    """A tiny Llama taught the answer for BOXES, saved as a local model folder; an
    untrained one beside it; and a LoRA adapter for the taught one."""
    root = tmp_path_factory.mktemp("llm")
    prompt = build_prompt(BOXES)
    answer = format_program(PROGRAM) + "\n"
    tokenizer = _char_tokenizer(prompt + answer + "0123456789-[](),='_#\n abcdefghijklmnopqrstuvwxyz")
    ids = tokenizer(prompt + answer, return_tensors="pt")["input_ids"]
    ids = torch.cat([ids, torch.tensor([[tokenizer.eos_token_id]])], dim=1)
    n_prompt = len(tokenizer(prompt)["input_ids"])
    labels = ids.clone()
    labels[:, :n_prompt] = -100  # learn the completion only

    untrained = _tiny_model(len(tokenizer))
    untrained.save_pretrained(root / "untrained")
    tokenizer.save_pretrained(root / "untrained")

    model = _tiny_model(len(tokenizer))
    opt = torch.optim.Adam(model.parameters(), lr=1e-2)
    for _ in range(400):
        loss = model(input_ids=ids, labels=labels).loss
        opt.zero_grad()
        loss.backward()
        opt.step()
        if loss.item() < 0.02:  # greedy decoding is exact well before this
            break
    model.save_pretrained(root / "taught")
    tokenizer.save_pretrained(root / "taught")

    from peft import LoraConfig, get_peft_model

    lora = get_peft_model(model, LoraConfig(r=4, target_modules=["q_proj", "v_proj"]))
    lora.save_pretrained(root / "adapter")  # B = 0 at init: the same answers
    return root


def test_local_model_predicts_through_the_parser(folders):
    predictor = get_predictor("llm", path=folders / "taught")
    assert predictor.predict(BOXES) == PROGRAM


def test_lora_adapter_loads_on_top(folders):
    predictor = LLMPredictor.from_pretrained(folders / "taught", adapter=folders / "adapter")
    assert type(predictor.model).__name__.startswith("Peft")
    assert predictor.predict(BOXES) == PROGRAM


def test_untrained_model_output_is_refused_with_a_clear_error(folders):
    predictor = LLMPredictor.from_pretrained(folders / "untrained", max_new_tokens=40)
    with pytest.raises(CodeFormatError):
        predictor.predict(BOXES)


def test_missing_folders_are_named(tmp_path, folders):
    with pytest.raises(Real2CodeError, match="no config.json"):
        LLMPredictor.from_pretrained(tmp_path)
    with pytest.raises(Real2CodeError, match="no adapter_config.json"):
        LLMPredictor.from_pretrained(folders / "taught", adapter=tmp_path)


def test_completion_is_cut_after_the_program():
    text = "root_geom = 0\nchild_joints = [\n dict(box=1, type='slide', idx=0),\n]\nprint('x')"
    assert completion_code("  # here\n" + text).endswith("]")
    with pytest.raises(CodeFormatError, match="no `root_geom"):
        completion_code("I cannot help with that")
