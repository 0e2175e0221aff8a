"""Build the Blender extension: bundle the wheels the add-on needs, build the zip with
Blender's own extension tool, and validate it.

    python blender_addon/build.py wheels              download the pinned wheels (cached)
    python blender_addon/build.py build [--out DIR]   wheels, stage, build, validate

Run it with a Python that has the ``bpy`` wheel (``.venv-blender``): Blender's extension
command-line tool, ``blender_ext.py``, ships inside it. Everything it writes goes under
``build/blender_addon/`` (ignored by git) unless ``--out`` says otherwise; the zip is
``real2code-<version>-linux_x64.zip``.

The project's own package goes in as one more wheel, built from ``real2code_export/`` as it is
in this checkout, so the add-on runs the same model, readers and writers as the command line.
"""

from __future__ import annotations

import argparse
import importlib.util
import re
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

ADDON = Path(__file__).resolve().parent
REPO = ADDON.parent
BUILD = REPO / "build" / "blender_addon"
WHEEL_CACHE = BUILD / "wheels"
MANIFEST = "blender_manifest.toml"
PACKAGE = "real2code_export"
# Blender platform -> the pip platform tags its compiled wheels are fetched for (pip takes an
# explicit --platform literally: the older manylinux tags a glibc-2.28 Blender also runs are
# listed too, for wheels built only for those).
PIP_PLATFORMS = {"linux-x64": ("manylinux_2_28_x86_64", "manylinux2014_x86_64")}
PYTHON_VERSION = "3.11"  # Blender 4.2 to 5.0


class BuildError(Exception):
    pass


def blender_ext_tool() -> Path:
    """``blender_ext.py`` inside the installed ``bpy`` package (found without importing bpy)."""
    spec = importlib.util.find_spec("bpy")
    if spec is None or spec.origin is None:
        raise BuildError(f"{sys.executable} has no bpy: run scripts/setup_blender.sh and use "
                         ".venv-blender/bin/python")
    found = sorted(Path(spec.origin).parent.glob("*/scripts/addons_core/bl_pkg/cli/blender_ext.py"))
    if not found:
        raise BuildError(f"blender_ext.py not found under {Path(spec.origin).parent}")
    return found[-1]


def _run(cmd: list[str]) -> str:
    done = subprocess.run(cmd, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise BuildError(f"{' '.join(map(str, cmd[:4]))} ... failed (exit {done.returncode}):\n"
                         f"{done.stdout}{done.stderr}")
    return done.stdout


def _requirement_names(path: Path) -> list[str]:
    names = []
    for line in path.read_text().splitlines():
        line = line.split("#", 1)[0].strip()
        if line:
            names.append(re.split(r"[=<>!~ ;]", line, maxsplit=1)[0])
    return names


def _wheel_for(name: str, folder: Path) -> Path:
    """The wheel of distribution ``name`` in ``folder`` (wheel names normalise - . to _)."""
    norm = re.sub(r"[-_.]+", "_", name).lower()
    found = [w for w in folder.glob("*.whl") if w.name.split("-")[0].lower() == norm]
    if len(found) != 1:
        raise BuildError(f"expected one wheel of {name} in {folder}, found {[w.name for w in found]}")
    return found[0]


def fetch_wheels(cache: Path = WHEEL_CACHE) -> list[Path]:
    """Download every pinned wheel (hashes checked by pip) into ``cache``; return their paths."""
    cache.mkdir(parents=True, exist_ok=True)
    wheels = []
    lists = {"any": ADDON / "wheels-any.txt"}
    lists |= {p: ADDON / f"wheels-{p}.txt" for p in PIP_PLATFORMS}
    for platform, requirements in lists.items():
        tags = ("any",) if platform == "any" else PIP_PLATFORMS[platform]
        _run([sys.executable, "-m", "pip", "download", "--quiet", "--no-deps",
              "--only-binary=:all:", "--python-version", PYTHON_VERSION,
              *(arg for tag in tags for arg in ("--platform", tag)),
              "--require-hashes", "-r", str(requirements), "-d", str(cache)])
        wheels += [_wheel_for(n, cache) for n in _requirement_names(requirements)]
    return wheels


def project_version() -> str:
    return tomllib.loads((REPO / "pyproject.toml").read_text())["project"]["version"]


def project_wheel(out: Path) -> Path:
    """``real2code_export`` as a pure-Python wheel, built by pip from a staged copy of the
    package alone (no ``pipeline``, no node_modules). It declares no dependencies: the
    extension bundles them as wheels of their own, for Blender's numpy 1.x."""
    src = BUILD / "project"
    shutil.rmtree(src, ignore_errors=True)
    shutil.copytree(REPO / PACKAGE, src / PACKAGE,
                    ignore=shutil.ignore_patterns("__pycache__", "node_modules"))
    version = project_version()
    (src / "pyproject.toml").write_text(
        '[build-system]\nrequires = ["setuptools>=70"]\nbuild-backend = "setuptools.build_meta"\n'
        f'[project]\nname = "{PACKAGE}"\nversion = "{version}"\nrequires-python = ">=3.11"\n'
        'dependencies = []\n'
        f'[tool.setuptools.packages.find]\ninclude = ["{PACKAGE}*"]\n'
        f'[tool.setuptools.package-data]\n{PACKAGE} = ["py.typed", '
        '"formats/gltf_validator/package*.json", "formats/gltf_validator/*.js"]\n')
    out.mkdir(parents=True, exist_ok=True)
    target = out / f"{PACKAGE}-{version}-py3-none-any.whl"
    target.unlink(missing_ok=True)
    _run([sys.executable, "-m", "pip", "wheel", "--quiet", "--no-deps", "--no-build-isolation",
          "-w", str(out), str(src)])
    if not target.is_file():
        raise BuildError(f"pip wheel did not write {target}")
    return target


def manifest_wheels(source: Path = ADDON) -> list[str]:
    manifest = tomllib.loads((source / MANIFEST).read_text())
    return [Path(w).name for w in manifest.get("wheels", [])]


def stage(wheels: list[Path], stage_dir: Path) -> Path:
    """The extension's source folder as Blender's tool wants it: the add-on's modules, the
    manifest and ``wheels/``. The manifest's wheel list must be exactly ``wheels``."""
    listed, have = set(manifest_wheels()), {w.name for w in wheels}
    if listed != have:
        raise BuildError(f"{ADDON / MANIFEST}: wheels list differs from the pinned wheels: "
                         f"listed only {sorted(listed - have)}, built only {sorted(have - listed)}")
    shutil.rmtree(stage_dir, ignore_errors=True)
    shutil.copytree(ADDON, stage_dir, ignore=shutil.ignore_patterns("__pycache__", "*.zip"))
    (stage_dir / "wheels").mkdir()
    for w in wheels:
        shutil.copy2(w, stage_dir / "wheels" / w.name)
    return stage_dir


def build(out: Path = BUILD) -> Path:
    """Fetch, stage, build and validate; return the zip."""
    wheels = fetch_wheels() + [project_wheel(BUILD / "project-wheel")]
    source = stage(wheels, BUILD / "real2code")
    tool = blender_ext_tool()
    out.mkdir(parents=True, exist_ok=True)
    _run([sys.executable, str(tool), "build", "--source-dir", str(source),
          "--output-dir", str(out), "--split-platforms"])
    version = tomllib.loads((ADDON / MANIFEST).read_text())["version"]
    zips = [out / f"real2code-{version}-{p.replace('-', '_')}.zip" for p in PIP_PLATFORMS]
    for z in zips:
        if not z.is_file():
            raise BuildError(f"blender_ext.py build did not write {z}")
        validate(z)
    return zips[0]


def validate(package: Path) -> str:
    """Blender's extension validator on a zip or source folder; raises on any problem."""
    return _run([sys.executable, str(blender_ext_tool()), "validate", str(package)])


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("what", choices=["wheels", "build"])
    p.add_argument("--out", type=Path, default=BUILD, help=f"where the zip goes (default {BUILD})")
    args = p.parse_args(argv)
    try:
        if args.what == "wheels":
            for w in fetch_wheels():
                print(w)
        else:
            print(build(args.out))
    except BuildError as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
