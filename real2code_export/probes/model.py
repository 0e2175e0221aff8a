"""The model's own answer: object.json loaded by its reader, posed by
:func:`real2code_export.model.forward_kinematics` (the reference the other probes meet)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..errors import CheckError, FormatError
from ..model import ArticulatedObject, forward_kinematics
from . import JointInfo

LABEL = "model (object.json)"


class ModelProbe:
    label = LABEL

    def __init__(self, obj: ArticulatedObject, path: Path):
        self.obj = obj
        self.path = path
        self.joints = [
            JointInfo(j.name, j.type.value,
                      None if j.limits is None else j.limits.lower,
                      None if j.limits is None else j.limits.upper)
            for j in obj.movable_joints
        ]
        self.parts = [p.name for p in obj.parts]
        # The captured state: check.py poses every file at it (configuration 1).
        self.observed = obj.observed_configuration()

    def poses(self, q: dict[str, float]) -> dict[str, np.ndarray]:
        return forward_kinematics(self.obj, q)

    def pose_array(self, values: np.ndarray) -> np.ndarray:
        """World poses for many configurations at once: ``values`` (N, len(joints)) in the
        order of ``self.joints`` -> (N, len(parts), 4, 4) in the order of ``self.parts``.

        The same kinematics as :meth:`poses`, vectorised over configurations (Rodrigues'
        formula on arrays) because a check poses every part hundreds of times.
        """
        values = np.atleast_2d(np.asarray(values, dtype=np.float64))
        n = len(values)
        column = {info.name: k for k, info in enumerate(self.joints)}
        world = {self.obj.root.name: np.broadcast_to(np.eye(4), (n, 4, 4))}
        for j in self.obj.joints_in_tree_order():
            local = np.broadcast_to(j.origin, (n, 4, 4)).copy()
            if j.type.movable:  # ball / floating: held at the origin, as fixed
                q = values[:, column[j.name]]
                if j.type.angular:
                    x, y, z = j.axis
                    k = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
                    rot = (np.eye(3) + np.sin(q)[:, None, None] * k
                           + (1.0 - np.cos(q))[:, None, None] * (k @ k))
                    local[:, :3, :3] = j.origin[:3, :3] @ rot
                else:
                    local[:, :3, 3] += (j.origin[:3, :3] @ j.axis) * q[:, None]
            world[j.child] = world[j.parent] @ local
        return np.stack([world[name] for name in self.parts], axis=1)


def open_probes(path: str | Path) -> list[ModelProbe]:
    """object.json read by its own reader, meshes left out: kinematics needs none, and
    parsing them (and importing trimesh) would cost more than the whole rest of a check.
    (Its reader is imported here, when a file needs it: ``check`` imports this module for
    :data:`LABEL`, and most checks have no object.json.)"""
    from ..formats import object_json

    path = Path(path)
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        if isinstance(data, dict) and isinstance(data.get("parts"), list):
            data["parts"] = [
                {**part, "visual": None, "texture": None, "collision": []}
                if isinstance(part, dict) else part
                for part in data["parts"]
            ]
        obj = object_json.from_dict(data, path)
    except (json.JSONDecodeError, UnicodeDecodeError) as e:
        raise CheckError(f"{path}: malformed JSON: {e}") from e
    except FormatError as e:
        raise CheckError(str(e)) from e
    return [ModelProbe(obj, path)]
