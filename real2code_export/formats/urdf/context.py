"""The state one URDF read carries: the file (for messages), caches, and number parsing
that names the file, the element and the line on every problem."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from lxml import etree

from ...errors import FormatError, warn
from ...meshfiles import MeshFile
from ...model import Mesh
from .conventions import NAMESPACE, PREFIX
from .xacro_file import is_xacro


def label(el: etree._Element) -> str:
    """How messages name an element: ``<joint name='hinge'>`` or ``<origin>``."""
    name = el.get("name")
    return f"<{el.tag} name='{name}'>" if name is not None else f"<{el.tag}>"


@dataclass
class Context:
    path: Path
    # Mesh files are often referenced twice (visual and collision): read each once.
    meshes: dict[tuple, Mesh] = field(default_factory=dict)
    files: dict[Path, MeshFile] = field(default_factory=dict)  # each file's colours, map_Kd
    # Repairs reported once per file (listing the links or joints), not once per element.
    notes: dict[str, list[str]] = field(default_factory=dict)
    # A <mujoco><compiler meshdir|assetdir> extension: the folder (relative to the URDF) in
    # which MuJoCo looks for a relative mesh filename.
    meshdir: str | None = None
    # package:// and model:// filenames resolved plainly (found in a package folder), by
    # filename: the look ahead and the read resolve each, visuals and collisions share them.
    packaged: dict[str, Path] = field(default_factory=dict)
    # The folders whose package.xml names a package, by name (a crawl of folders: once per
    # read, not once per mesh filename)
    manifests: dict[str, list[Path]] = field(default_factory=dict)
    # Relative mesh filenames found not beside the URDF but under a folder above it (an asset
    # root), by folder: said once per file.
    asset_roots: dict[Path, list[str]] = field(default_factory=dict)
    _folder: Path | None = field(default=None, repr=False)

    def folder(self) -> Path:
        """The URDF's folder, its links resolved (once per read: every package:// filename
        is looked for from it, and resolving a path is a system call per folder in it)."""
        if self._folder is None:
            self._folder = self.path.resolve().parent
        return self._folder

    def note(self, kind: str, name: str) -> None:
        self.notes.setdefault(kind, []).append(name)

    def error(self, owner: str | None, message: str, line: int | None) -> FormatError:
        message, line = self._expanded(message, line)
        return FormatError(self.path, owner, message, line)

    def _expanded(self, message: str, line: int | None) -> tuple[str, int | None]:
        """A line of a xacro file's expansion is no line of the file: said as such."""
        if line is None or not is_xacro(self.path):
            return message, line
        return f"{message} (line {line} of the URDF `xacro {self.path.name}` prints)", None

    def warn(self, owner: str | None, message: str, line: int | None = None) -> None:
        message, line = self._expanded(message, line)
        where = f"{self.path}:{line}" if line is not None else str(self.path)
        warn(f"{where}: {owner}: {message}" if owner else f"{where}: {message}")

    def floats(self, el: etree._Element, attr: str, owner: str, *, count: int | tuple[int, ...],
               default: tuple[float, ...] | None = None) -> np.ndarray:
        """The whitespace-separated numbers of ``el.attr`` (``count`` of them, or one of the
        counts in a tuple); ``default`` when absent, else an error. Non-finite is an error."""
        text = el.get(attr)
        where = f"<{el.tag}> {attr.replace('{' + NAMESPACE + '}', PREFIX + ':')}"
        if text is None:
            if default is None:
                raise self.error(owner, f"{where} is missing", el.sourceline)
            return np.array(default, dtype=float)
        try:
            values = [float(v) for v in text.split()]
        except ValueError as e:
            xacro = " (unexpanded xacro: expand the file with xacro first)" \
                if "${" in text or "$(" in text else ""
            raise self.error(owner, f"{where}={text!r} is not a list of numbers{xacro}",
                             el.sourceline) from e
        counts = (count,) if isinstance(count, int) else count
        if len(values) not in counts:
            want = " or ".join(str(c) for c in counts)
            raise self.error(owner, f"{where}={text!r} must have {want} number(s)", el.sourceline)
        if not all(math.isfinite(v) for v in values):
            raise self.error(owner, f"{where}={text!r} is not finite", el.sourceline)
        return np.array(values, dtype=float)

    def number(self, el: etree._Element, attr: str, owner: str,
               default: float | None = None) -> float:
        d = None if default is None else (default,)
        return float(self.floats(el, attr, owner, count=1, default=d)[0])
