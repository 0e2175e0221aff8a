"""A model file handed to MuJoCo as MuJoCo loads it from the file's own folder.

MuJoCo (4.0) joins the relative asset paths of an included file wrongly when the model's own
path is relative: Genesis's ``xml/franka_sim/franka_panda.xml``, whose ``assets/assets.xml``
names ``../meshes/collision/link0.stl``, says "Error opening file" from any other folder and
loads from its absolute path. Every MJCF or URDF given to MuJoCo goes through here.
"""

from __future__ import annotations

from pathlib import Path


def mujoco_path(path: str | Path) -> str:
    """The file's absolute path, as MuJoCo's loaders take it."""
    return str(Path(path).resolve())


def spec_from_file(path: str | Path):
    """``mujoco.MjSpec.from_file`` of the file at :func:`mujoco_path`."""
    import mujoco

    return mujoco.MjSpec.from_file(mujoco_path(path))
