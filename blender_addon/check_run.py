"""``real2code check`` on exported files, from inside Blender.

The full check loads each file in its own tool: MuJoCo, Pinocchio, the UsdPhysics parser, a
glTF reader and the Khronos validator (Node.js). Pinocchio needs numpy >= 2 and Blender's
Python has numpy 1.x, so the full check runs as a subprocess: the ``real2code`` command of
the project's own environment (its path is an add-on preference, or ``real2code`` on PATH).
Without one, the probes that do load in Blender's Python run here (the model, MuJoCo on MJCF,
UsdPhysics through Blender's pxr, pygltflib on glTF) and the result names what was skipped.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import tempfile
from dataclasses import asdict, dataclass, field
from pathlib import Path

import bpy

from real2code_export.errors import CheckError
from real2code_export.formats import FORMATS

TIMEOUT_S = 600.0
USD_SUFFIXES = FORMATS["usd"].suffixes


@dataclass
class CheckOutcome:
    ok: bool
    how: str  # which check ran: the command line, or the partial check inside Blender
    table: str  # the check's own text table
    probes: list[dict] = field(default_factory=list)  # label, name, ok, errors, worst part
    mismatches: list[str] = field(default_factory=list)
    skipped: list[str] = field(default_factory=list)

    def to_json(self) -> str:
        return json.dumps(asdict(self))

    @classmethod
    def from_json(cls, text: str) -> CheckOutcome:
        return cls(**json.loads(text))

    def summary(self) -> str:
        state = "passed" if self.ok else f"FAILED ({len(self.mismatches)} mismatches)"
        text = f"check {state}: {len(self.probes)} probes ({self.how})"
        if self.skipped:
            text += f"; skipped {len(self.skipped)}"
        return text


def find_executable(preference: str) -> str | None:
    """The ``real2code`` command: the preference when set, else ``real2code`` on PATH."""
    if preference:
        path = Path(bpy.path.abspath(preference))  # may be relative to the .blend (//)
        if not path.is_file():
            raise CheckError(f"{path}: the real2code command set in the add-on preferences "
                             "does not exist")
        return str(path)
    return shutil.which("real2code")


def _outcome(report: dict, how: str, table: str, skipped: list[str]) -> CheckOutcome:
    probes = [{"name": p["name"], "ok": p["ok"], "reference": p["reference"],
               "max_position_error": p["max_position_error"],
               "max_rotation_error": p["max_rotation_error"], "worst_part": p["worst_part"]}
              for p in report["probes"]]
    mismatches = [m["message"] if m["message"].startswith(m["probe"])
                  else f"{m['probe']}: {m['message']}" for m in report["mismatches"]]
    return CheckOutcome(bool(report["ok"]) and not mismatches, how, table, probes, mismatches,
                        skipped)


def run_full(executable: str, files: list[Path], configurations: int = 100) -> CheckOutcome:
    """``real2code check FILES --json OUT`` in its own process; its report, read back."""
    with tempfile.TemporaryDirectory(prefix="real2code-check-") as tmp:
        out = Path(tmp) / "check.json"
        cmd = [executable, "check", *map(str, files), "--json", str(out),
               "--configurations", str(configurations)]
        try:
            done = subprocess.run(cmd, capture_output=True, text=True, timeout=TIMEOUT_S,
                                  check=False)
        except (OSError, subprocess.TimeoutExpired) as e:
            raise CheckError(f"{executable} check could not run: {e}") from e
        if done.returncode not in (0, 1) or not out.is_file():
            tail = (done.stderr or done.stdout).strip().splitlines()[-5:]
            raise CheckError(f"{executable} check failed (exit {done.returncode}): "
                             + " | ".join(tail))
        report = json.loads(out.read_text())
    return _outcome(report, f"{Path(executable).name} check", done.stdout.strip(), [])


def run_inside(files: list[Path], configurations: int = 100) -> CheckOutcome:
    """The probes that load in Blender's Python, with the rest named as skipped."""
    from real2code_export.check import check_files, format_table
    from real2code_export.validators import validate_usd

    from .usd_support import ensure_pxr

    usable, skipped = [], []
    for f in files:
        suffix = f.suffix.lower()
        if suffix in FORMATS["urdf"].suffixes:
            skipped.append(f"{f.name}: URDF is checked by Pinocchio and MuJoCo together, and "
                           "Pinocchio needs numpy >= 2 (not in Blender's Python)")
        elif suffix in USD_SUFFIXES and (reason := _usd_probe_problem(f, ensure_pxr)):
            skipped.append(f"{f.name}: {reason}")
        else:
            usable.append(f)
    if any(f.suffix.lower() in FORMATS["gltf"].suffixes for f in usable):
        skipped.append("Khronos glTF validator: needs Node.js and its npm package, not run "
                       "inside Blender")
    report = check_files(usable, n_configurations=configurations, validate=False)
    report.validations += validate_usd([f for f in usable if f.suffix.lower() in USD_SUFFIXES])
    result = report.to_json()
    for v in report.validations:
        if v.errors:
            result["mismatches"].append({"kind": "validation", "probe": v.tool, "name": v.path,
                                         "message": f"{v.errors} error(s) in {v.path}: "
                                                    + "; ".join(v.messages[:3])})
    return _outcome(result, "partial check inside Blender", format_table(report), skipped)


def _usd_probe_problem(path: Path, ensure_pxr) -> str | None:
    """Why the project's USD probe cannot run on Blender's own pxr, or None when it can
    (Blender's OpenUSD release may lack a function the project's usd-core has)."""
    if not ensure_pxr():
        return "this Blender has no pxr (USD Python modules)"
    from real2code_export.probes.usd import open_probes

    try:
        open_probes(path)
    except AttributeError as e:
        return f"the USD probe does not run on this Blender's OpenUSD ({e})"
    return None
