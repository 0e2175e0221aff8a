"""Headless Blender (the ``bpy`` wheel) with the add-on installed from its built zip.

Run in the add-on's own venv: ``.venv-blender/bin/python -m pytest blender_addon/tests``.
The session builds the extension zip, installs it through Blender's own extension installer
into a temporary user folder (never ``~/.config/blender``) and enables it, exactly as a user
installing the zip gets it. Inputs and references come from the main venv (numpy 2,
Pinocchio): ``real2code generate``/``export`` make the objects, ``fk_reference.py`` the
forward kinematics, ``real2code check`` the full check. Tests skip, saying why, when the main
venv or ../shared/data is missing.
"""

from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

ADDON = Path(__file__).resolve().parents[1]
REPO = ADDON.parent
MAIN_BIN = REPO / ".venv" / "bin"
REAL2CODE = MAIN_BIN / "real2code"
SHARED_DATA = Path(os.environ.get("REAL2CODE_SHARED_DATA", REPO.parent / "shared" / "data"))
MODULE = "bl_ext.user_default.real2code"
# category -> (parts, seed) for the generated inputs
CATEGORIES = {"storage_furniture": (6, 3), "table": (4, 1), "refrigerator": (3, 2),
              "laptop": (2, 0), "box": (2, 5)}
INPUT_FORMATS = ("json", "urdf", "mjcf", "gltf")
EXPORTED = ("urdf", "mjcf", "gltf", "usd")

# Blender reads its user folder when bpy is first imported: point it at a fresh one first.
os.environ["BLENDER_USER_RESOURCES"] = tempfile.mkdtemp(prefix="real2code-blender-user-")


def forget_checkout() -> None:
    """The add-on must get real2code_export from the wheel its zip bundles, as in Blender.
    `python -m pytest` puts the checkout on sys.path, and pytest imports the source package
    ``blender_addon/__init__.py`` (and so the checkout's real2code_export) while collecting:
    take both back before the extension is installed."""
    sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != REPO]
    for name in list(sys.modules):
        if name.split(".")[0] in ("real2code_export", "blender_addon"):
            del sys.modules[name]


def main_venv() -> Path:
    if not REAL2CODE.is_file():
        pytest.skip(f"the main venv's {REAL2CODE} is missing: run scripts/setup.sh first")
    return MAIN_BIN


def run_main(args: list[str], stdin: str | None = None) -> str:
    done = subprocess.run(args, input=stdin, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(map(str, args))} failed ({done.returncode}):\n"
                           f"{done.stdout}\n{done.stderr}")
    return done.stdout


def fk_reference(requests: list[dict]) -> dict:
    """Poses from the main venv's model (see fk_reference.py)."""
    python = main_venv() / "python"
    return json.loads(run_main([str(python), str(ADDON / "tests" / "fk_reference.py")],
                               stdin=json.dumps(requests)))


def partnet_dev() -> list[Path]:
    index = SHARED_DATA / "partnet_mobility" / "index.json"
    if not index.is_file():
        return []
    return [index.parent / e["id"] / "mobility.urdf" for e in json.loads(index.read_text())
            if e["split"] == "dev"]


def partnet_ids() -> list[str]:
    return [p.parent.name for p in partnet_dev()] or ["absent"]


def partnet_urdf(object_id: str) -> Path:
    if object_id == "absent":
        pytest.skip(f"PartNet-Mobility data not found at {SHARED_DATA / 'partnet_mobility'} "
                    "(set REAL2CODE_SHARED_DATA)")
    return SHARED_DATA / "partnet_mobility" / object_id / "mobility.urdf"


# -- the extension -------------------------------------------------------------------------------
@pytest.fixture(scope="session")
def extension_zip(tmp_path_factory) -> Path:
    """The extension built from this checkout (build.py: wheels, staging, blender_ext.py)."""
    return load_build_script().build(tmp_path_factory.mktemp("extension"))


def load_build_script():
    spec = importlib.util.spec_from_file_location("real2code_addon_build", ADDON / "build.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="session")
def installed(extension_zip):
    """The zip installed by Blender's extension installer; returns the add-on's module."""
    import bpy

    forget_checkout()
    result = bpy.ops.extensions.package_install_files(
        filepath=str(extension_zip), repo="user_default", enable_on_install=True)
    assert result == {"FINISHED"}
    return sys.modules[MODULE]


@pytest.fixture
def blender(installed):
    """An empty scene with the add-on enabled and pointed at the main venv's real2code."""
    import bpy

    # read_homefile, not read_factory_settings: the factory settings disable every add-on,
    # and enabling an extension again re-syncs its wheels (seconds per test).
    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    assert MODULE in bpy.context.preferences.addons
    prefs = bpy.context.preferences.addons[MODULE].preferences
    prefs.real2code_executable = str(REAL2CODE) if REAL2CODE.is_file() else ""
    prefs.check_configurations = 20
    return bpy


def addon_module(name: str):
    """A module of the installed add-on (``from_blender``, ``panel``, ...)."""
    return importlib.import_module(f"{MODULE}.{name}")


# -- inputs from the main venv ---------------------------------------------------------------
@pytest.fixture(scope="session")
def generated(tmp_path_factory) -> dict[str, dict[str, Path]]:
    """category -> format -> file: ``real2code generate`` then ``real2code export``."""
    bin_dir = main_venv()
    root = tmp_path_factory.mktemp("generated")

    def make(category: str) -> dict[str, Path]:
        parts, seed = CATEGORIES[category]
        out = root / category
        run_main([str(bin_dir / "real2code"), "generate", "--category", category,
                  "--parts", str(parts), "--seed", str(seed), "--out", str(out)])
        said = run_main([str(bin_dir / "real2code"), "export", str(out / "object.json"),
                         "--to", ",".join(EXPORTED), "--out", str(out / "export")])
        # the files as the export names them (``<format> <path>``: the registry's names)
        written = dict(line.split(maxsplit=1) for line in said.splitlines() if line.strip())
        return {"json": out / "object.json"} | {f: Path(written[f]) for f in EXPORTED}

    with ThreadPoolExecutor(max_workers=2) as pool:
        return dict(zip(CATEGORIES, pool.map(make, CATEGORIES), strict=True))


def scene_snapshot(bpy) -> dict[str, list[str]]:
    """Every datablock name a failed import or export must leave alone."""
    return {kind: sorted(getattr(bpy.data, kind).keys())
            for kind in ("objects", "meshes", "materials", "collections", "actions")} | {
        "scene objects": sorted(o.name for o in bpy.context.scene.objects)}
