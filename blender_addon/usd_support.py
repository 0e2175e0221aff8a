"""USD through the ``pxr`` Python modules that ship inside Blender.

Blender bundles OpenUSD with its Python bindings (with UsdPhysics) in its own
``python/lib/python3.X/site-packages``. Blender itself has that folder on ``sys.path``;
Blender built as a Python module (the ``bpy`` wheel the tests run) keeps it out, so the
folder is added here, once, and only when ``pxr`` is not importable already. Nothing is
installed: these are Blender's own files.

The project's USD writer applies NewtonMassAPI/NewtonJointAPI, whose schemas the bundled
``newton_usd_schemas`` registers on import. USD builds its schema registry once, at first
use (Blender's own USD importer and exporter use the same library), so the add-on calls
``ensure_pxr`` when it is registered, before any stage is opened.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import bpy


def bundled_site_packages() -> Path:
    version = f"python{sys.version_info.major}.{sys.version_info.minor}"
    return Path(bpy.utils.resource_path("LOCAL")) / "python" / "lib" / version / "site-packages"


def ensure_pxr() -> bool:
    """Make Blender's ``pxr`` importable with the Newton schemas registered; False when this
    Blender has no pxr."""
    if importlib.util.find_spec("pxr") is None:
        folder = bundled_site_packages()
        if not (folder / "pxr").is_dir():
            return False
        sys.path.append(str(folder))
        if importlib.util.find_spec("pxr") is None:
            return False
    import newton_usd_schemas  # noqa: F401  (registers its schemas with USD's plug-in registry)

    return True
