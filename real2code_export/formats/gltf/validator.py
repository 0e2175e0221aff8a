"""The Khronos glTF validator, run through Node.js.

The validator is the npm package ``gltf-validator`` (Dart compiled to JS, a library only),
pinned in ``real2code_export/formats/gltf_validator/package.json`` and installed there with
``npm ci``; ``validate.js`` beside it reads files and prints the reports as JSON.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

from ...errors import CheckError

VALIDATOR_DIR = Path(__file__).resolve().parents[1] / "gltf_validator"
SCRIPT = VALIDATOR_DIR / "validate.js"
INSTALL_HINT = f"install it with: cd {VALIDATOR_DIR} && npm ci   (needs Node.js >= 18)"
SEVERITIES = {0: "error", 1: "warning", 2: "info", 3: "hint"}


class ValidatorUnavailable(CheckError):
    """Node.js or the gltf-validator package is not installed."""


def _summary(report: dict[str, Any]) -> dict[str, Any]:
    if "fatal" in report:  # the validator could not even classify the bytes
        return {"errors": 1, "warnings": 0, "infos": 0, "hints": 0,
                "messages": [{"severity": "error", "code": "FATAL", "message": report["fatal"],
                              "pointer": None}], "report": report}
    issues = report.get("issues", {})
    messages = [{"severity": SEVERITIES.get(m.get("severity"), str(m.get("severity"))),
                 "code": m.get("code"), "message": m.get("message"),
                 "pointer": m.get("pointer") or m.get("offset")}
                for m in issues.get("messages", [])]
    return {"errors": issues.get("numErrors", 0), "warnings": issues.get("numWarnings", 0),
            "infos": issues.get("numInfos", 0), "hints": issues.get("numHints", 0),
            "messages": messages, "validator_version": report.get("validatorVersion"),
            "report": report}


def validate_gltf_files(paths: list[str | Path], timeout: float = 300.0) -> list[dict[str, Any]]:
    """Validate several files in one Node.js run (startup dominates for small files).

    Each result: ``errors``, ``warnings``, ``infos``, ``hints`` (counts), ``messages``
    (severity, code, message, pointer) and the validator's full ``report``.
    """
    return start_gltf_validation(paths, timeout)()


def start_gltf_validation(paths: list[str | Path], timeout: float = 300.0
                          ) -> Callable[[], list[dict[str, Any]]]:
    """Start the validator on ``paths`` (one Node.js process) and return the function that
    waits for it and gives :func:`validate_gltf_files`' results: the caller works meanwhile
    (``real2code check`` loads its probes)."""
    paths = [Path(p) for p in paths]
    if not paths:
        return list
    for p in paths:
        if not p.is_file():
            raise CheckError(f"{p}: no such file")
    node = shutil.which("node")
    if node is None:
        raise ValidatorUnavailable(f"the glTF validator needs Node.js (`node` not on PATH); "
                                   f"{INSTALL_HINT}")
    if not (VALIDATOR_DIR / "node_modules" / "gltf-validator").is_dir():
        raise ValidatorUnavailable(f"npm package gltf-validator is not installed; {INSTALL_HINT}")
    # the report goes to a file, not a pipe: a pipe nobody reads yet would stall the validator
    out = tempfile.TemporaryFile()  # noqa: SIM115 - finish() closes both
    err = tempfile.TemporaryFile()  # noqa: SIM115
    process = subprocess.Popen([node, str(SCRIPT), *map(str, paths)], stdout=out, stderr=err)

    def finish() -> list[dict[str, Any]]:
        with out, err:
            try:
                code = process.wait(timeout=timeout)
            except subprocess.TimeoutExpired as e:
                process.kill()
                process.wait()
                raise CheckError(f"glTF validator ran past {timeout} s") from e
            out.seek(0)
            err.seek(0)
            stdout, stderr = out.read().decode(errors="replace"), err.read().decode(errors="replace")
        if code != 0:
            raise CheckError(f"glTF validator failed (exit {code}): {stderr.strip()}")
        try:
            reports = json.loads(stdout)
        except json.JSONDecodeError as e:
            raise CheckError(f"glTF validator printed no JSON report: {stdout[:200]!r}") from e
        return [_summary(r) for r in reports]

    return finish


def validate_gltf(path: str | Path) -> dict[str, Any]:
    """The Khronos validator's report on one .glb/.gltf file (see validate_gltf_files)."""
    return validate_gltf_files([path])[0]
