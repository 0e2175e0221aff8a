"""Small objects built in code for tests that must not depend on the generator."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh

from real2code_export import transforms as tf
from real2code_export.model import (
    ArticulatedObject,
    Dynamics,
    Inertial,
    Joint,
    Limits,
    Mesh,
    Part,
)


def box_mesh(extents, center=(0.0, 0.0, 0.0)) -> Mesh:
    m = trimesh.creation.box(extents=extents)
    m.apply_translation(center)
    return Mesh.from_trimesh(m)


def box_inertial(extents, mass, center=(0.0, 0.0, 0.0)) -> Inertial:
    x, y, z = extents
    inertia = mass / 12.0 * np.diag([y * y + z * z, x * x + z * z, x * x + y * y])
    return Inertial(mass, np.asarray(center, float), inertia)


def small_cabinet() -> ArticulatedObject:
    """A cabinet: body, a door on an off-axis hinge, a drawer, a fixed handle, a knob."""
    body = Part("body", visual=box_mesh([0.5, 0.6, 0.8], [0, 0, 0.4]),
                collision=[box_mesh([0.5, 0.6, 0.8], [0, 0, 0.4])],
                inertial=box_inertial([0.5, 0.6, 0.8], 20.0, [0, 0, 0.4]), color=(0.6, 0.4, 0.2, 1))
    door = Part("door", visual=box_mesh([0.02, 0.3, 0.4], [0, 0.15, 0]),
                collision=[box_mesh([0.02, 0.3, 0.4], [0, 0.15, 0])],
                inertial=box_inertial([0.02, 0.3, 0.4], 2.0, [0, 0.15, 0]), color=(0.8, 0.8, 0.8, 1))
    drawer = Part("drawer", visual=box_mesh([0.4, 0.28, 0.15]),
                  collision=[box_mesh([0.4, 0.28, 0.15])],
                  inertial=box_inertial([0.4, 0.28, 0.15], 1.5), color=(0.2, 0.3, 0.9, 1))
    handle = Part("handle", visual=box_mesh([0.03, 0.02, 0.1]),
                  collision=[box_mesh([0.03, 0.02, 0.1])],
                  inertial=box_inertial([0.03, 0.02, 0.1], 0.1))
    knob = Part("knob", visual=box_mesh([0.02, 0.03, 0.03]),
                collision=[box_mesh([0.02, 0.03, 0.03])],
                inertial=box_inertial([0.02, 0.03, 0.03], 0.05))
    axis = np.array([0.0, 0.1, 1.0]) / np.linalg.norm([0.0, 0.1, 1.0])
    joints = [
        Joint("door_hinge", "revolute", "body", "door",
              origin=tf.make(tf.rpy_to_matrix([0.0, 0.0, 0.1]), [0.26, -0.3, 0.6]), axis=axis,
              limits=Limits(0.0, 1.6, effort=5.0, velocity=2.0),
              dynamics=Dynamics(damping=0.5, friction=0.1, stiffness=0.2, spring_ref=0.1,
                                armature=0.01), state=0.4),
        Joint("drawer_slide", "prismatic", "body", "drawer", origin=tf.make(None, [0.05, 0.1, 0.2]),
              axis=[1.0, 0.0, 0.0], limits=Limits(0.0, 0.35), dynamics=Dynamics(damping=2.0),
              state=0.12),
        Joint("handle_mount", "fixed", "drawer", "handle", origin=tf.make(None, [0.22, 0.0, 0.0])),
        Joint("knob_turn", "continuous", "door", "knob",
              origin=tf.make(tf.rpy_to_matrix([0.3, -0.2, 0.5]), [0.02, 0.25, 0.1]),
              axis=[1.0, 0.0, 0.0], state=-0.7),
    ]
    return ArticulatedObject("small_cabinet", [body, door, drawer, handle, knob], joints,
                             metadata={"category": "storage_furniture", "source": "tests"})


def laptop_with_laws() -> ArticulatedObject:
    """A small object for the dynamic check: one hinge under gravity, light to simulate,
    observed part open (our MJCF then writes ref = the state, which engines must not take
    for the joint value), with damping and dry friction for the laws experiment."""
    from pipeline.procedural import generate

    obj = generate("laptop", seed=3)
    for j in obj.movable_joints:
        j.dynamics.damping, j.dynamics.friction = 0.05, 0.02
        j.state = j.limits.lower + 0.3 * (j.limits.upper - j.limits.lower)
    return obj


def edit_glb(path: Path, edit) -> None:
    """Rewrite a .glb's JSON chunk through ``edit(document)``, its binary chunk kept."""
    import json
    import struct

    data = path.read_bytes()
    size = struct.unpack_from("<I", data, 12)[0]
    doc = json.loads(data[20:20 + size])
    edit(doc)
    text = json.dumps(doc).encode()
    text += b" " * (-len(text) % 4)
    rest = data[20 + size:]
    body = struct.pack("<I", len(text)) + b"JSON" + text + rest
    path.write_bytes(data[:8] + struct.pack("<I", 12 + len(body)) + body)
