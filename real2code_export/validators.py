"""The formats' own validators, run by ``real2code check`` beside the kinematic comparison:
the Khronos glTF validator for .glb/.gltf, the UsdValidation validators (physics, geometry,
shading, core) for USD. MJCF and URDF have no separate validator: MuJoCo's compiler and
Pinocchio's urdfdom parser, which the probes run, are theirs."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

USD_VALIDATOR_KEYWORDS = ["UsdPhysicsValidators", "UsdGeomValidators", "UsdShadeValidators",
                          "UsdCoreValidators"]


@dataclass
class Validation:
    path: str
    tool: str
    errors: int
    warnings: int
    messages: list[str] = field(default_factory=list)  # errors first, then warnings

    def to_json(self) -> dict:
        return {"path": self.path, "tool": self.tool, "errors": self.errors,
                "warnings": self.warnings, "messages": self.messages}


def validate_usd(paths: list[Path]) -> list[Validation]:
    return [_validate_usd(p) for p in paths]


def _validate_usd(path: Path) -> Validation:
    from pxr import Usd, UsdValidation

    stage = Usd.Stage.Open(str(path))
    context = UsdValidation.ValidationContext(keywords=USD_VALIDATOR_KEYWORDS)
    found = context.Validate(stage)
    kind = UsdValidation.ValidationErrorType
    errors = [f"{e.GetName()}: {e.GetMessage()}" for e in found if e.GetType() == kind.Error]
    warnings = [f"{e.GetName()}: {e.GetMessage()}" for e in found if e.GetType() == kind.Warn]
    return Validation(str(path), "UsdValidation", len(errors), len(warnings), errors + warnings)


def validate_gltf(paths: list[Path]) -> list[Validation]:
    return start_validate_gltf(paths)()


def start_validate_gltf(paths: list[Path]) -> Callable[[], list[Validation]]:
    """:func:`validate_gltf` started (the validator is a Node.js process): the function
    returned waits for it."""
    from .formats.gltf.validator import start_gltf_validation

    results = start_gltf_validation(paths)

    def finish() -> list[Validation]:
        out = []
        for path, result in zip(paths, results(), strict=True):
            ordered = sorted(result["messages"], key=lambda m: m["severity"] != "error")
            messages = [f"{m['code']}: {m['message']} ({m['pointer']})" for m in ordered
                        if m["severity"] in ("error", "warning")]
            out.append(Validation(str(path), "Khronos glTF validator", result["errors"],
                                  result["warnings"], messages))
        return out

    return finish


def validate_files(paths: list[str | Path]) -> list[Validation]:
    """Run every validator the registry names for ``paths`` (files of formats without one,
    or of no known format, are skipped), one call per validator with all of its files."""
    return start_validation(paths)()


def start_validation(paths: list[str | Path]) -> Callable[[], list[Validation]]:
    """:func:`validate_files` in two steps: a validator that runs in another process (its
    module has ``start_<function>``, as the glTF one) starts now; the function returned runs
    the others and collects every result. ``real2code check`` loads its probes in between,
    in this one thread (native libraries' imports deadlock when two threads run them)."""
    import importlib
    from functools import partial

    from .errors import Real2CodeError
    from .formats import format_for_path

    groups: dict[str, list[Path]] = {}
    for p in map(Path, paths):
        try:
            validator = format_for_path(p).validator
        except Real2CodeError:
            continue
        if validator:
            groups.setdefault(validator, []).append(p)
    steps = []
    for validator, files in groups.items():
        module_name, function = validator.split(":")
        module = importlib.import_module(module_name)
        start = getattr(module, f"start_{function}", None)
        steps.append(start(files) if start is not None else partial(getattr(module, function),
                                                                     files))
    return lambda: [v for step in steps for v in step()]
