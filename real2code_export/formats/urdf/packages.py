"""Where a URDF's packages are: the folders ``package://NAME`` and xacro's ``$(find NAME)``
are looked for in (there is no ROS package index here); and the arguments a xacro file is
expanded with (``real2code --xacro-arg``)."""

from __future__ import annotations

import functools
import os
import xml.etree.ElementTree as ET
from collections.abc import Iterator
from pathlib import Path

# A folder holding one of these is left out of ROS's package crawl (catkin, colcon, ament).
_IGNORE_MARKERS = ("CATKIN_IGNORE", "COLCON_IGNORE", "AMENT_IGNORE")
# How deep below a search-path folder package manifests are looked for (ws/src/repo/pkg).
_CRAWL_DEPTH = 3


def package_search_path() -> list[Path]:
    """Folders named by ``ROS_PACKAGE_PATH`` (ROS) and ``GZ_SIM_RESOURCE_PATH`` /
    ``GAZEBO_MODEL_PATH`` (Gazebo's ``model://``), in that order; ``real2code
    --package-path`` prepends to the first."""
    folders = []
    for var in ("ROS_PACKAGE_PATH", "GZ_SIM_RESOURCE_PATH", "GAZEBO_MODEL_PATH"):
        folders += [Path(p) for p in os.environ.get(var, "").split(os.pathsep) if p]
    return folders


def find_package(name: str, start: Path) -> Path | None:
    """The folder of package ``name``: one named so, or holding one so named, among
    ``start`` and its parents, then in the search path; else the one whose ``package.xml``
    names it (:func:`manifest_packages`)."""
    for folder in (start, *start.parents, *package_search_path()):
        if folder.name == name and folder.is_dir():
            return folder
        if (folder / name).is_dir():
            return folder / name
    return next(manifest_packages(name, start), None)


def manifest_packages(name: str, start: Path) -> Iterator[Path]:
    """Folders whose ``package.xml`` names package ``name``, nearest first: ``start`` and
    its parents, the folders beside them (the other packages of a repository), then the
    search path crawled as ROS crawls it (into folders, not into a package, nor past an
    ignore marker). ROS finds a package by its manifest's ``<name>``, not its folder's
    (moveit_resources keeps ``moveit_resources_panda_description`` in ``panda_description/``)."""
    seen: set[Path] = set()
    for folder in (start, *start.parents):
        for candidate in (folder, *_subfolders(folder)):
            if candidate not in seen and _manifest_name(candidate) == name:
                seen.add(candidate)
                yield candidate
    for root in package_search_path():
        for candidate in _crawl(root, _CRAWL_DEPTH):
            if candidate not in seen and _manifest_name(candidate) == name:
                seen.add(candidate)
                yield candidate


def _subfolders(folder: Path) -> list[Path]:
    try:
        return sorted(p for p in folder.iterdir() if p.is_dir() and not p.name.startswith("."))
    except OSError:  # unreadable: nothing found there
        return []


def _crawl(folder: Path, depth: int) -> Iterator[Path]:
    if any((folder / marker).exists() for marker in _IGNORE_MARKERS):
        return
    yield folder
    if depth == 0 or (folder / "package.xml").is_file():
        return
    for sub in _subfolders(folder):
        yield from _crawl(sub, depth - 1)


@functools.lru_cache(maxsize=4096)
def _manifest_name(folder: Path) -> str | None:
    """The ``<name>`` of ``folder/package.xml`` (ROS's package manifest), or None."""
    manifest = folder / "package.xml"
    if not manifest.is_file():
        return None
    try:
        found = ET.parse(manifest).getroot().find("name")
    except (ET.ParseError, OSError):  # not a manifest we can read: not this package
        return None
    return found.text.strip() if found is not None and found.text else None


# ``real2code --xacro-arg NAME:=VALUE`` (repeatable) puts its arguments here, one a line, for
# the reader and the check's tools, as ``--package-path`` puts its folders in ROS_PACKAGE_PATH.
XACRO_ARGS_VARIABLE = "REAL2CODE_XACRO_ARGS"


def xacro_arguments() -> dict[str, str]:
    """The xacro arguments given (:data:`XACRO_ARGS_VARIABLE`), NAME -> VALUE; ValueError
    naming one that is not NAME:=VALUE."""
    out = {}
    for item in os.environ.get(XACRO_ARGS_VARIABLE, "").splitlines():
        name, sep, value = item.partition(":=")
        if not sep or not name.strip():
            raise ValueError(f"--xacro-arg {item!r} is not NAME:=VALUE")
        out[name.strip()] = value
    return out
