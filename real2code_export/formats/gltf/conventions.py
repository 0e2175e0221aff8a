"""What the glTF writer and reader share: names of our extras, the up-axis conversion, node
transforms and binary accessors.

Up axis: glTF is Y up, the model is Z up. The file's single scene root node carries the
conversion as its rotation (-90 degrees about X, taking model +Z to glTF +Y); every node
below it, every mesh and all joint metadata stay in the model's Z-up coordinates. A viewer
sees the object upright; our reader applies the inverse rotation to world transforms.
"""

from __future__ import annotations

import base64
import math
from pathlib import Path
from typing import Any

import numpy as np

from ... import transforms as tf
from ...errors import FormatError

EXTRAS_KEY = "real2code"  # our namespace inside node / primitive / animation extras
SCHEMA = "real2code_export/gltf"
SCHEMA_VERSION = 1
KHR_PHYSICS = "KHR_physics_rigid_bodies"
KHR_SHAPES = "KHR_implicit_shapes"

_H = math.sqrt(0.5)
ROOT_ROTATION_XYZW = [-_H, 0.0, 0.0, _H]  # -90 deg about X: model +Z -> glTF +Y
Y_UP_FROM_Z_UP = tf.make(rotation=tf.quat_to_matrix([_H, -_H, 0.0, 0.0]))
Z_UP_FROM_Y_UP = tf.inverse(Y_UP_FROM_Z_UP)

# glTF accessor component types and element sizes
FLOAT, UNSIGNED_BYTE, UNSIGNED_SHORT, UNSIGNED_INT = 5126, 5121, 5123, 5125
BYTE, SHORT = 5120, 5122
COMPONENT_DTYPES = {
    BYTE: np.int8, UNSIGNED_BYTE: np.uint8, SHORT: np.int16, UNSIGNED_SHORT: np.uint16,
    UNSIGNED_INT: np.uint32, FLOAT: np.float32,
}
TYPE_SIZES = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}
ARRAY_BUFFER, ELEMENT_ARRAY_BUFFER = 34962, 34963
TRIANGLES = 4
# sampler filters and wrap mode (glTF 2.0 spec, 5.26)
LINEAR, LINEAR_MIPMAP_LINEAR, REPEAT = 9729, 9987, 10497


def ours(extras: Any) -> dict[str, Any]:
    """Our namespaced extras of a glTF property ({} when absent)."""
    if isinstance(extras, dict) and isinstance(extras.get(EXTRAS_KEY), dict):
        return extras[EXTRAS_KEY]
    return {}


def khr(extensions: Any, name: str = KHR_PHYSICS) -> dict[str, Any]:
    if isinstance(extensions, dict) and isinstance(extensions.get(name), dict):
        return extensions[name]
    return {}


# -- transforms ------------------------------------------------------------------------------
def quat_xyzw(rotation: np.ndarray) -> list[float]:
    """glTF quaternion (x, y, z, w) of a rotation matrix."""
    w, x, y, z = tf.matrix_to_quat(rotation)
    return [float(x), float(y), float(z), float(w)]


def rotation_from_xyzw(q) -> np.ndarray:
    x, y, z, w = (float(v) for v in q)
    return tf.quat_to_matrix([w, x, y, z])


def axis_angle_xyzw(axis: np.ndarray, angle: float) -> list[float]:
    """Quaternion of ``angle`` about the unit ``axis``, directly (no matrix round trip)."""
    s = math.sin(0.5 * angle)
    return [float(axis[0] * s), float(axis[1] * s), float(axis[2] * s), math.cos(0.5 * angle)]


def node_matrix(node) -> np.ndarray:
    """A node's local transform (4x4) from ``matrix`` (column-major) or TRS."""
    if node.matrix:
        return np.asarray(node.matrix, dtype=float).reshape(4, 4).T
    t = np.eye(4)
    if node.scale:
        t[:3, :3] = np.diag(np.asarray(node.scale, dtype=float))
    if node.rotation:
        t[:3, :3] = rotation_from_xyzw(node.rotation) @ t[:3, :3]
    if node.translation:
        t[:3, 3] = node.translation
    return t


# -- binary data -----------------------------------------------------------------------------
def buffer_bytes(gltf, path: Path, index: int) -> bytes:
    """The bytes of buffer ``index`` (GLB binary chunk, data URI or external file)."""
    buffer = gltf.buffers[index]
    if buffer.uri is None:
        blob = gltf.binary_blob()
        if blob is None:
            raise FormatError(path, f"buffers[{index}]", "has no uri and the file has no binary chunk")
        return bytes(blob)
    if buffer.uri.startswith("data:"):
        try:
            return base64.b64decode(buffer.uri.split(",", 1)[1])
        except (IndexError, ValueError) as e:
            raise FormatError(path, f"buffers[{index}]", f"bad data URI: {e}") from e
    file = path.parent / buffer.uri
    if not file.is_file():
        raise FormatError(path, f"buffers[{index}]", f"buffer file not found: {file}")
    return file.read_bytes()


class AccessorReader:
    """Reads accessors as numpy arrays (float64 or int64), with clear errors."""

    def __init__(self, gltf, path: Path):
        self.gltf = gltf
        self.path = path
        self._buffers: dict[int, bytes] = {}

    def read(self, index: int) -> np.ndarray:
        el = f"accessors[{index}]"
        gltf = self.gltf
        if not 0 <= index < len(gltf.accessors):
            raise FormatError(self.path, el, "does not exist")
        acc = gltf.accessors[index]
        if acc.sparse is not None:
            raise FormatError(self.path, el, "sparse accessors are not supported")
        dtype = COMPONENT_DTYPES.get(acc.componentType)
        width = TYPE_SIZES.get(acc.type)
        if dtype is None or width is None:
            raise FormatError(self.path, el, f"unsupported componentType {acc.componentType} "
                                             f"or type {acc.type!r}")
        dtype = np.dtype(dtype).newbyteorder("<")
        count = int(acc.count)
        if acc.bufferView is None:  # all zeros by the spec
            out = np.zeros((count, width), dtype=dtype)
        else:
            view = gltf.bufferViews[acc.bufferView]
            if view.buffer not in self._buffers:
                self._buffers[view.buffer] = buffer_bytes(gltf, self.path, view.buffer)
            data = self._buffers[view.buffer]
            start = (view.byteOffset or 0) + (acc.byteOffset or 0)
            element = dtype.itemsize * width
            stride = view.byteStride or element
            end = start + stride * (count - 1) + element if count else start
            if end > (view.byteOffset or 0) + view.byteLength or end > len(data):
                raise FormatError(self.path, el, "reads past the end of its buffer view")
            raw = np.frombuffer(data, dtype=np.uint8, count=end - start, offset=start)
            if stride == element:
                out = raw.view(dtype).reshape(count, width)
            else:
                rows = np.lib.stride_tricks.as_strided(raw, shape=(count, element),
                                                       strides=(stride, 1))
                out = np.ascontiguousarray(rows).view(dtype).reshape(count, width)
        if dtype.kind == "f":
            out = out.astype(np.float64)
        elif acc.normalized:
            out = np.maximum(out.astype(np.float64) / np.iinfo(dtype).max, -1.0)
        else:
            out = out.astype(np.int64)
        return out if width > 1 else out.reshape(-1)
