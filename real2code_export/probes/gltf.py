"""glTF probe: the file's JSON read as the glTF 2.0 specification frames it (a .gltf is
JSON; a .glb a 12-byte header, then a JSON chunk) and posed from its own node tree.

Node transforms (TRS or matrix, float64 JSON) are composed from the scene roots down; for
each joint in the ``real2code`` node extras, the child part node's local transform (which
the file holds at the observed state) is replaced by the joint motion at the requested
value: a rotation of q about the joint axis, or a translation of q along it. World poses
are converted from glTF's Y up back to Z up. This reads the file as any glTF consumer
would; it shares no code with our writer or reader.

Files without our extras (e.g. from other tools) are probed through the model importer
instead (KHR_physics_rigid_bodies joints, or fixed parts), and labelled so.
"""

from __future__ import annotations

import json
import struct
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from .. import transforms as tf
from ..errors import CheckError, NameNotFoundError, Real2CodeError
from . import JointInfo, joint_motions

LABEL = "glTF (nodes + joint metadata)"
EXTRAS_KEY = "real2code"
_ONE_VALUE = ("revolute", "continuous", "prismatic")  # joint kinds posed by a value
# glTF world (Y up) -> model world (Z up): +90 degrees about X
Z_UP_FROM_Y_UP = np.array([[1.0, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 0], [0, 0, 0, 1]])


def _local(node) -> np.ndarray:
    if node.matrix:
        return np.asarray(node.matrix, dtype=float).reshape(4, 4).T  # column-major
    t = np.eye(4)
    if node.scale:
        t[:3, :3] = np.diag(node.scale)
    if node.rotation:
        x, y, z, w = node.rotation
        t[:3, :3] = tf.quat_to_matrix([w, x, y, z]) @ t[:3, :3]
    if node.translation:
        t[:3, 3] = node.translation
    return t


_NODE_FIELDS = ("name", "children", "matrix", "translation", "rotation", "scale", "extras")


def _document(path: Path) -> dict:
    """The glTF JSON. Only the node tree is read: pygltflib's typed load decodes every
    accessor and mesh into dataclasses, most of a check's time for a robot's glTF."""
    data = path.read_bytes()
    if data[:4] == b"glTF":  # GLB: magic, version, length; chunk length, type "JSON", data
        if len(data) < 20 or data[16:20] != b"JSON":
            raise CheckError(f"{path}: not a GLB with a JSON first chunk")
        size = struct.unpack_from("<I", data, 12)[0]
        data = data[20:20 + size]
    try:
        doc = json.loads(data)
    except (UnicodeDecodeError, json.JSONDecodeError) as e:
        raise CheckError(f"{path}: its glTF JSON cannot be read: {e}") from e
    if not isinstance(doc, dict):
        raise CheckError(f"{path}: its glTF JSON is not an object")
    return doc


def _extras(node) -> dict:
    extras = node.extras if isinstance(node.extras, dict) else {}
    data = extras.get(EXTRAS_KEY)
    return data if isinstance(data, dict) else {}


class GltfProbe:
    label = LABEL

    def __init__(self, path: str | Path):
        self.path = Path(path)
        doc = _document(self.path)
        self.document = doc  # (the dynamics against a source read its physics extension)
        nodes, scenes = doc.get("nodes"), doc.get("scenes")
        if not isinstance(nodes, list) or not nodes or not all(isinstance(n, dict)
                                                               for n in nodes):
            raise CheckError(f"{self.path}: no nodes")
        self.nodes = [SimpleNamespace(**{k: n.get(k) for k in _NODE_FIELDS}) for n in nodes]
        scene = scenes[doc.get("scene") or 0] if isinstance(scenes, list) and scenes else None
        children = {c for n in self.nodes for c in (n.children or [])}
        self.roots = list(scene.get("nodes") or []) if isinstance(scene, dict) else \
            [i for i in range(len(self.nodes)) if i not in children]
        part_nodes = {_extras(n)["part"]: i for i, n in enumerate(self.nodes) if "part" in _extras(n)}
        self.parts = list(part_nodes)
        self._part_nodes = set(part_nodes.values())
        self._locals = [_local(n) for n in self.nodes]  # once: poses() runs per configuration
        self.joints: list[JointInfo] = []
        self._motion: dict[int, tuple[str, str, np.ndarray]] = {}  # child node -> joint
        for i, node in enumerate(self.nodes):
            d = _extras(node)
            if "joint" not in d or "type" not in d:
                continue
            child = part_nodes.get(d.get("child"))
            if child is None or child not in (node.children or []):
                raise CheckError(f"{self.path}: nodes[{i}]: joint {d['joint']!r} has no child "
                                 f"part node {d.get('child')!r} below it")
            axis = np.asarray(d.get("axis", [0, 0, 1]), dtype=float)
            self._motion[child] = (d["joint"], d["type"], axis)
            if d["type"] in _ONE_VALUE:  # ball / floating: held at the written pose
                lim = d.get("limits") or {}
                self.joints.append(JointInfo(d["joint"], d["type"], lim.get("lower"),
                                             lim.get("upper")))

    def poses(self, q: dict[str, float]) -> dict[str, np.ndarray]:
        known = {j.name for j in self.joints}
        unknown = set(q) - known
        if unknown:
            raise NameNotFoundError(f"unknown joint(s) {sorted(unknown)} in {self.path}")
        values = np.array([[float(q.get(j.name, 0.0)) for j in self.joints]])
        return {name: pose[0] for name, pose in self._world_poses(values).items()}

    def pose_array(self, values) -> np.ndarray:
        """(N, len(joints)) joint values in the order of ``joints`` -> (N, len(parts), 4, 4),
        every configuration at once."""
        values = np.atleast_2d(np.asarray(values, dtype=float))
        poses = self._world_poses(values)
        return np.stack([poses[name] for name in self.parts], axis=1)

    def _world_poses(self, values: np.ndarray) -> dict[str, np.ndarray]:
        """Part node name -> (N, 4, 4) world poses (Z up) at the N rows of ``values``."""
        world = self.node_poses(values)
        return {self.nodes[i].name: world[i] for i in world if i in self._part_nodes}

    def node_poses(self, values: np.ndarray) -> dict[int, np.ndarray]:
        """Node index -> (N, 4, 4) world pose (Z up) of every node in the scene at the N rows
        of ``values`` (joint values in the order of ``joints``)."""
        values = np.atleast_2d(np.asarray(values, dtype=float))
        n = len(values)
        column = {j.name: k for k, j in enumerate(self.joints)}
        world: dict[int, np.ndarray] = {}
        stack = [(r, np.broadcast_to(Z_UP_FROM_Y_UP, (n, 4, 4))) for r in reversed(self.roots)]
        while stack:
            i, parent = stack.pop()
            local = self._locals[i]
            if i in self._motion:  # the joint's motion replaces the written (observed) pose
                name, kind, axis = self._motion[i]
                q = values[:, column[name]] if name in column else np.zeros(n)
                local = joint_motions(kind, axis, q)
            world[i] = parent @ local
            stack.extend((c, world[i]) for c in reversed(self.nodes[i].children or []))
        return world


class ImportedGltfProbe:
    """A glTF without our extras, posed through the model importer."""

    label = "glTF (imported: KHR_physics_rigid_bodies / node tree)"

    def __init__(self, path: str | Path):
        from ..formats.gltf import load
        from ..model import forward_kinematics

        self.path = Path(path)
        try:
            self.obj = load(self.path)
        except Real2CodeError as e:
            raise CheckError(str(e)) from e
        self._fk = forward_kinematics
        self.parts = [p.name for p in self.obj.parts]
        self.joints = [JointInfo(j.name, j.type.value, j.limits.lower if j.limits else None,
                                 j.limits.upper if j.limits else None)
                       for j in self.obj.movable_joints]

    def poses(self, q: dict[str, float]) -> dict[str, np.ndarray]:
        return self._fk(self.obj, q)


def open_probes(path: str | Path) -> list:
    probe = GltfProbe(path)
    if probe.parts:
        return [probe]
    return [ImportedGltfProbe(path)]


__all__ = ["GltfProbe", "ImportedGltfProbe", "open_probes"]
