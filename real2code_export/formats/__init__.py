"""Format registry: one module per file format, each with ``load(path)`` and/or
``save(obj, out_dir, *, write_meshes=True) -> Path``, found by name or by extension.

Modules are imported only when used, so ``import real2code_export`` stays light and a
missing optional dependency only affects its own format. No format module imports another.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType

from .. import atomic
from ..errors import FormatError
from ..meshfiles import write_object_meshes
from ..model import ArticulatedObject, validate


@dataclass(frozen=True)
class Format:
    name: str  # as on the command line: --to mjcf,urdf,usd,gltf
    module: str
    extensions: tuple[str, ...]
    output_suffix: str  # the file an export writes: DIR/<object name><suffix>

    def load_module(self) -> ModuleType:
        return importlib.import_module(self.module)


FORMATS: dict[str, Format] = {
    f.name: f
    for f in (
        Format("json", "real2code_export.formats.object_json", (".json",), ".json"),
        Format("mjcf", "real2code_export.formats.mjcf", (".xml", ".mjcf"), ".xml"),
        Format("urdf", "real2code_export.formats.urdf", (".urdf",), ".urdf"),
        Format("usd", "real2code_export.formats.usd", (".usda", ".usd", ".usdc"), ".usda"),
        Format("gltf", "real2code_export.formats.gltf", (".glb", ".gltf"), ".glb"),
    )
}
EXPORT_FORMATS = ("mjcf", "urdf", "usd", "gltf")


def format_for_path(path: str | Path) -> Format:
    suffix = Path(path).suffix.lower()
    for fmt in FORMATS.values():
        if suffix in fmt.extensions:
            return fmt
    known = sorted(e for f in FORMATS.values() for e in f.extensions)
    raise FormatError(path, None, f"unknown file type {suffix!r} (known: {', '.join(known)})")


def load(path: str | Path) -> ArticulatedObject:
    """Load any supported file into the model; the format is chosen by extension."""
    path = Path(path)
    if not path.exists():
        raise FormatError(path, None, "no such file")
    if path.is_dir():
        candidate = path / "object.json"
        if candidate.is_file():
            path = candidate
        else:
            raise FormatError(path, None, "is a folder without object.json")
    module = format_for_path(path).load_module()
    if not hasattr(module, "load"):
        raise FormatError(path, None, f"format {module.__name__} cannot be read")
    return module.load(path)


def export(obj: ArticulatedObject, out_dir: str | Path,
           formats: tuple[str, ...] | list[str] = EXPORT_FORMATS) -> dict[str, Path]:
    """Write ``obj`` in each format into ``out_dir`` atomically: all files or none.

    Meshes are written once and shared by every format's file.
    """
    out_dir = Path(out_dir)
    with atomic.staged_output(out_dir) as staging:
        staged = write_formats(obj, staging, formats)
    return {name: out_dir / path.relative_to(staging) for name, path in staged.items()}


def write_formats(obj: ArticulatedObject, folder: str | Path,
                  formats: tuple[str, ...] | list[str] = EXPORT_FORMATS) -> dict[str, Path]:
    """Write ``obj`` in each format into ``folder`` (a staging folder: not atomic by itself,
    see :func:`export`)."""
    unknown = [f for f in formats if f not in FORMATS]
    if unknown:
        raise FormatError(None, "--to", f"unknown format(s) {unknown}; choose from {list(FORMATS)}")
    validate(obj)
    modules = {name: FORMATS[name].load_module() for name in formats}
    folder = Path(folder)
    # object.json wants exact mesh text; the other formats share the same files.
    write_object_meshes(obj, folder, exact="json" in formats)
    return {name: Path(module.save(obj, folder, write_meshes=False))
            for name, module in modules.items()}
