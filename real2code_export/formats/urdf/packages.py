"""Where a URDF's packages are: the folders ``package://NAME`` and xacro's ``$(find NAME)``
are looked for in (there is no ROS package index here); and the arguments a xacro file is
expanded with (``real2code --xacro-arg``)."""

from __future__ import annotations

import os
from pathlib import Path


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
    ``start`` and its parents, then in the search path."""
    for folder in (start, *start.parents, *package_search_path()):
        if folder.name == name and folder.is_dir():
            return folder
        if (folder / name).is_dir():
            return folder / name
    return None


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
