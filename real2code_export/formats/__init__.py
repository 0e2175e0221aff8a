"""The format registry: every fact about a file format in one place, asked by everything else
(the CLI's choices and defaults, batch inputs, ``check``'s probes and validators, calibrate's
exports, the Blender add-on).

A format is a module with ``load(path)`` and/or ``save(obj, out_dir, *, write_meshes=True)
-> Path``, found by name or by suffix. Its module and the imports it needs are imported only
when used: this module imports nothing but the standard library, so the CLI's parser and
``import real2code_export`` stay light. :func:`available` really imports a format's
dependencies and its module (once; the answer is cached), so a package that is installed but
broken makes its format unavailable, with the reason, instead of failing mid-command. No
format module imports another.

To add a format, :func:`register` it (here, or from a plug-in): the CLI, batch, check and the
add-on offer it from then on.
"""

from __future__ import annotations

import functools
import importlib
import inspect
import re
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING

from ..errors import FormatError, UnavailableError

if TYPE_CHECKING:
    from ..model import ArticulatedObject


@dataclass(frozen=True)
class Format:
    name: str  # as on the command line: --to mjcf,urdf,usd,gltf
    label: str  # as shown to people (the add-on's menus)
    description: str
    module: str  # has load(path) and/or save(obj, out_dir, *, write_meshes)
    suffixes: tuple[str, ...]  # files of this format; the first is what an export writes
    requires: tuple[str, ...] = ()  # modules the format's writer (and reader) cannot work without
    # and those its reader alone needs (USD: the schema modules; the writer authors through Sdf)
    read_requires: tuple[str, ...] = ()
    probes: tuple[str, ...] = ()  # modules whose open_probes(path) load it in its own tools
    validator: str | None = None  # "module:function", function(list[Path]) -> [Validation]
    # (and start_<function>, where the module has one: validators.start_validation)
    exported: bool = True  # written by default (``export`` without --to)
    mesh_files: bool = True  # its file refers to the shared meshes/*.obj (else it holds its own)
    # the metadata key under which its reader keeps what the model has no place for, and its
    # writer writes back (actuators, <transmission>, ...); other writers carry it as metadata
    kept_elements: str | None = None
    lossless: bool = False  # holds the model itself, metadata and all (object.json)
    # its consumers take the convex hull of each collision mesh themselves (USD's
    # physics:approximation = convexHull, glTF's convexHull collider): an export to such
    # formats alone reads the source with hull_collision=False and computes no hulls
    hulls_collision: bool = False

    @property
    def output_suffix(self) -> str:
        """The file an export writes: DIR/<object name><suffix>."""
        return self.suffixes[0]

    def load_module(self, *, writing: bool = False) -> ModuleType:
        """The format's module; UnavailableError (exit 2) naming why when it cannot be used
        here (``writing``: to write files, which may need fewer imports than reading)."""
        problem = unavailable_reason(self.name, writing=writing)
        if problem:
            raise UnavailableError(f"format {self.name!r} is not available here: {problem}")
        return importlib.import_module(self.module)


def output_file(name: str, out_dir: str | Path, object_name: str) -> Path:
    """The file format ``name``'s writer writes for object ``object_name``:
    ``out_dir/<object_name><output suffix>`` (writers ask here, not restate their suffix)."""
    return Path(out_dir) / f"{object_name}{FORMATS[name].output_suffix}"


FORMATS: dict[str, Format] = {}
# (format name, writing only) -> why it cannot be used so here (None: it can)
_PROBLEMS: dict[tuple[str, bool], str | None] = {}


def register(fmt: Format) -> Format:
    """Add (or replace) a format; everything that offers formats asks :data:`FORMATS`."""
    FORMATS[fmt.name] = fmt
    for writing in (False, True):
        _PROBLEMS.pop((fmt.name, writing), None)
    return fmt


_P = "real2code_export.probes."
# ROS's macro files for URDF, read as the URDF they expand to (formats/urdf/xacro_file.py)
XACRO_SUFFIX = ".xacro"
for _fmt in (
    Format("json", "object.json", "The project's own lossless format",
           "real2code_export.formats.object_json", (".json",), probes=(_P + "model",),
           exported=False, lossless=True),
    Format("mjcf", "MJCF", "MuJoCo", "real2code_export.formats.mjcf", (".xml", ".mjcf"),
           requires=("mujoco",), probes=(_P + "mujoco",), kept_elements="mjcf_elements"),
    Format("urdf", "URDF", "URDF (ROS, Pinocchio, Isaac, ...)", "real2code_export.formats.urdf",
           (".urdf", XACRO_SUFFIX), requires=("lxml.etree",),
           probes=(_P + "mujoco", _P + "pinocchio"),
           kept_elements="urdf_elements"),
    Format("usd", "USD", "USD with UsdPhysics joints", "real2code_export.formats.usd",
           (".usda", ".usd", ".usdc"), requires=("pxr.Sdf",),
           read_requires=("pxr.Usd", "pxr.UsdPhysics"),
           probes=(_P + "usd",), validator="real2code_export.validators:validate_usd",
           mesh_files=False, hulls_collision=True),
    Format("gltf", "glTF", "Binary glTF with KHR physics joints", "real2code_export.formats.gltf",
           (".glb", ".gltf"), requires=("pygltflib",), probes=(_P + "gltf",),
           validator="real2code_export.validators:validate_gltf", mesh_files=False,
           hulls_collision=True),
):
    register(_fmt)


def names_from_modules(package: str, modules: dict[str, str]):
    """A format package's module ``__getattr__``: each public name (``load``, ``save``, ...)
    imported from its module (``modules``: name -> module in ``package``) when first asked
    for, so that a command imports only the direction and the parts it uses (an export to
    USD no reader; a check of a .glb or an MJCF file not the format's reader and writer)."""
    def __getattr__(name: str):
        if name not in modules:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        return getattr(importlib.import_module(f"{package}.{modules[name]}"), name)

    return __getattr__


# -- availability --------------------------------------------------------------------------------


def unavailable_reason(name: str, *, writing: bool = False) -> str | None:
    """Why format ``name`` cannot be read and written here (``writing``: cannot be written;
    its imports fail), or None when it can. Imports its dependencies and its module the
    first time; cached."""
    if name not in FORMATS:
        raise FormatError(None, "--to", f"unknown format {name!r}; choose from "
                          f"{', '.join(FORMATS)}")
    key = (name, writing)
    if key not in _PROBLEMS:
        _PROBLEMS[key] = _import_problem(FORMATS[name], writing)
    return _PROBLEMS[key]


def _import_problem(fmt: Format, writing: bool) -> str | None:
    for module in (*fmt.requires, fmt.module, *(() if writing else fmt.read_requires)):
        try:
            importlib.import_module(module)
        except Exception as e:  # noqa: BLE001 - a broken package fails in any way it likes
            return f"cannot import {module} ({type(e).__name__}: {e})"
    # a package that imports its writer and reader when first asked (USD's): import them
    for name in ("save",) if writing else ("save", "load"):
        try:
            getattr(importlib.import_module(fmt.module), name, None)
        except Exception as e:  # noqa: BLE001
            return f"cannot import {fmt.module}.{name} ({type(e).__name__}: {e})"
    return None


def imported(name: str) -> bool:
    """Whether format ``name``'s libraries were imported already here (its availability was
    asked and it is available): a command run by the server (cli/server_loop.py) finds them so."""
    return any(_PROBLEMS.get((name, writing), "") is None for writing in (False, True))


def available(name: str) -> bool:
    """Whether format ``name`` can be read and written here (its imports really work)."""
    return unavailable_reason(name) is None


def forget_availability() -> None:
    """Ask again next time (after installing a package, or in tests)."""
    _PROBLEMS.clear()


def export_formats() -> list[str]:
    """The formats an export writes by default: every exported format that can be written
    here."""
    return [f.name for f in FORMATS.values()
            if f.exported and unavailable_reason(f.name, writing=True) is None]


def hulls_collision(formats: list[str] | tuple[str, ...]) -> bool:
    """Whether every one of ``formats`` leaves the collision meshes' convex hulls to its
    consumers (:attr:`Format.hulls_collision`), so that no reader need compute them."""
    return bool(formats) and all(FORMATS[name].hulls_collision for name in formats)


def suffixes(exported_only: bool = False) -> tuple[str, ...]:
    """Every file suffix the registry knows (model files), in registration order."""
    return tuple(s for f in FORMATS.values() if f.exported or not exported_only
                 for s in f.suffixes)


def is_format(path: str | Path, name: str) -> bool:
    """Whether ``path`` is a file of format ``name``: named with one of its suffixes (an
    existing ``.xml`` by its root element, :func:`format_for_path`)."""
    if Path(path).suffix.lower() == ".xml" and name in ("urdf", "mjcf"):
        return _xml_format(Path(path)) == name
    return Path(path).suffix.lower() in FORMATS[name].suffixes


# The root element of an XML file that is a URDF: ROS tools never cared for the suffix, and
# older ROS packages name their URDF ``robot.xml`` (pr2_description); MuJoCo's loader, too,
# takes an .xml file whose root is <robot> as a URDF.
URDF_ROOT = "robot"


def _xml_format(path: Path) -> str:
    """``urdf`` for an existing ``.xml`` file whose root element is <robot>, else ``mjcf``
    (the suffix's format: a file not there yet, or unreadable, is left to its reader)."""
    try:
        stat = path.stat()
    except OSError:
        return "mjcf"
    return "urdf" if _root_element(str(path), stat.st_mtime_ns, stat.st_size) == URDF_ROOT \
        else "mjcf"


@functools.lru_cache(maxsize=256)
def _root_element(path: str, _mtime_ns: int, _size: int) -> str | None:
    """The name of the first element of an XML file (past its declaration, comments,
    processing instructions and DOCTYPE), from its first 64 KiB; None where none is found."""
    try:
        with open(path, "rb") as f:
            head = f.read(1 << 16).decode("utf-8", "replace")
    except OSError:
        return None
    head = re.sub(r"<!--.*?(-->|$)|<\?.*?(\?>|$)|<!DOCTYPE[^>]*>", "", head, flags=re.S)
    found = re.search(r"<\s*([A-Za-z_][\w.:-]*)", head)
    return found.group(1).split(":")[-1] if found else None


def format_for_path(path: str | Path) -> Format:
    suffix = Path(path).suffix.lower()
    if suffix == ".xml":
        return FORMATS[_xml_format(Path(path))]
    for fmt in FORMATS.values():
        if suffix in fmt.suffixes:
            return fmt
    raise FormatError(path, None, f"unknown file type {suffix!r} "
                      f"(known: {', '.join(sorted(suffixes()))})")


def parse_names(text: str) -> list[str]:
    """``--to mjcf,urdf`` -> ["mjcf", "urdf"]; FormatError naming the unknown ones."""
    names = [t.strip().lower() for t in text.split(",") if t.strip()]
    bad = [n for n in names if n not in FORMATS]
    if bad or not names:
        raise FormatError(None, "--to", f"unknown format(s) {bad or text!r}; choose from "
                          f"{', '.join(FORMATS)}")
    return names


# -- reading and writing ------------------------------------------------------------------------
def load(path: str | Path, *, faithful_collision: bool = False,
         hull_collision: bool = True) -> ArticulatedObject:
    """Load any supported file into the model; the format is chosen by suffix.

    ``faithful_collision``: collision made from the visual geometry keeps hollow parts'
    insides and no two parts' pieces overlap (readers that make pieces: URDF); files whose
    pieces are authored as convex pieces (ours, MJCF, USD) are read as they are.
    ``hull_collision=False``: readers that make pieces keep the collision meshes as the file
    gives them instead, each standing for its convex hull (as a piece read from MJCF or USD
    does), for a caller that writes only formats whose consumers take those hulls
    themselves (:func:`hulls_collision`)."""
    path = Path(path)
    if not path.exists():
        raise FormatError(path, None, "no such file")
    if path.is_dir():
        candidate = path / "object.json"
        if candidate.is_file():
            path = candidate
        else:
            raise FormatError(path, None, "is a folder without object.json")
    fmt = format_for_path(path)
    module = fmt.load_module()
    if not hasattr(module, "load"):
        raise FormatError(path, None, f"format {fmt.name!r} cannot be read")
    options = {"faithful_collision": faithful_collision, "hull_collision": hull_collision}
    accepted = inspect.signature(module.load).parameters
    return module.load(path, **{k: v for k, v in options.items()
                                if k in accepted and v != accepted[k].default})


def export(obj: ArticulatedObject, out_dir: str | Path,
           formats: tuple[str, ...] | list[str] | None = None) -> dict[str, Path]:
    """Write ``obj`` in each format (default: :func:`export_formats`) into ``out_dir``
    atomically: all files or none. Meshes are written once and shared by every format's file
    that refers to mesh files (:attr:`Format.mesh_files`; none when every format embeds them).
    """
    from .. import atomic

    out_dir = Path(out_dir)
    with atomic.staged_output(out_dir) as staging:
        staged = write_formats(obj, staging, formats)
    return {name: out_dir / path.relative_to(staging) for name, path in staged.items()}


def warn_kept_elements(obj: ArticulatedObject, formats: list[str]) -> None:
    """Say, for each format written, which elements another format's reader kept (in the
    metadata) it has no place for: they travel as metadata only."""
    from ..errors import warn

    for source in FORMATS.values():
        kept = obj.metadata.get(source.kept_elements) if source.kept_elements else None
        if not kept:
            continue
        what = ", ".join(f"<{t}>" for t in kept) if isinstance(kept, dict) else \
            f"{len(kept)} element(s)"
        for name in formats:
            fmt = FORMATS[name]
            if not fmt.lossless and fmt.kept_elements != source.kept_elements:
                warn(f"{fmt.label}: {obj.name!r}: the {source.label} elements kept in the "
                     f"metadata {source.kept_elements!r} ({what}) are carried as metadata "
                     f"only: {fmt.label} has no place for them")


def write_formats(obj: ArticulatedObject, folder: str | Path,
                  formats: tuple[str, ...] | list[str] | None = None) -> dict[str, Path]:
    """Write ``obj`` in each format (default: :func:`export_formats`) into ``folder`` (a
    staging folder: not atomic by itself, see :func:`export`)."""
    from ..meshfiles import write_object_meshes
    from ..model import validated

    formats = export_formats() if formats is None else list(formats)
    unknown = [f for f in formats if f not in FORMATS]
    if unknown:
        raise FormatError(None, "--to", f"unknown format(s) {unknown}; choose from {list(FORMATS)}")
    with validated(obj):  # once, not again by each writer
        modules = {name: FORMATS[name].load_module(writing=True) for name in formats}
        unwritable = [name for name, module in modules.items() if not hasattr(module, "save")]
        if unwritable:
            raise FormatError(None, "--to", f"format(s) {unwritable} cannot be written")
        folder = Path(folder)
        warn_kept_elements(obj, formats)
        # object.json wants exact mesh text; the other formats share the same files.
        if any(FORMATS[name].mesh_files for name in formats):
            write_object_meshes(obj, folder, exact="json" in formats)
        return {name: Path(module.save(obj, folder, write_meshes=False))
                for name, module in modules.items()}
