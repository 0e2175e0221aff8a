"""The executable program: Real2Code's code representation as a script that builds the
object in MuJoCo (MjSpec) from the part boxes, the part meshes and the predicted joints.

The script is generated from parsed, checked data (never from raw model output), so it is
safe to run; ``real2code articulate`` writes it beside the exports for inspection. As in the
paper, the bodies stay at the captured poses (every body frame is the world frame) and the
joints are placed in world coordinates.
"""

from __future__ import annotations

from .joint_code import ArticulationProgram
from .obb import OBB

_TEMPLATE = '''"""Built by real2code_export from part boxes and joints predicted as code.
Run it with Python (needs mujoco): it compiles the articulated object and prints a summary."""

from pathlib import Path

import mujoco
import numpy as np

HERE = Path(__file__).resolve().parent
bboxes = {bboxes}
part_meshes = {meshes}
root_geom = {root}
child_joints = [
{joints}]


def joint_frame(box, idx, edge, sign):
    """Absolute axis and position: box axis ``idx`` (times ``sign``) through the box edge
    picked by ``edge`` (the signs of the two other axes)."""
    R, c, e = np.array(box["R"]), np.array(box["center"]), np.array(box["extent"])
    a, b = [i for i in range(3) if i != idx]
    return sign * R[:, idx], c + edge[0] * e[a] * R[:, a] + edge[1] * e[b] * R[:, b]


def add_part(spec, body, i):
    box = bboxes[i]
    if part_meshes.get(i):
        spec.add_mesh(name=f"mesh_{{i}}", file=str(HERE / part_meshes[i]))
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_MESH, meshname=f"mesh_{{i}}")
    else:
        quat = np.zeros(4)
        mujoco.mju_mat2Quat(quat, np.array(box["R"]).ravel())
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=box["extent"], pos=box["center"],
                      quat=quat)


def build():
    spec = mujoco.MjSpec()
    spec.compiler.degree = False
    bodies = {{root_geom: spec.worldbody.add_body(name=f"part_{{root_geom}}")}}
    add_part(spec, bodies[root_geom], root_geom)
    pending = list(child_joints)
    while pending:
        for j in [j for j in pending if j.get("parent", root_geom) in bodies]:
            pending.remove(j)
            body = bodies[j.get("parent", root_geom)].add_body(name=f"part_{{j['box']}}")
            axis, pos = joint_frame(bboxes[j["box"]], j["idx"], j["edge"], j["sign"])
            kind = mujoco.mjtJoint.mjJNT_HINGE if j["type"] == "hinge" else mujoco.mjtJoint.mjJNT_SLIDE
            body.add_joint(name=f"joint_{{j['box']}}", type=kind, axis=axis, pos=pos)
            add_part(spec, body, j["box"])
            bodies[j["box"]] = body
    return spec


if __name__ == "__main__":
    model = build().compile()
    print(f"compiled: {{model.nbody - 1}} bodies, {{model.njnt}} joints")
'''


def _box_literal(box: OBB) -> str:
    return (f"{{'center': {box.center.tolist()!r}, 'R': {box.R.tolist()!r}, "
            f"'extent': {box.extent.tolist()!r}}}")


def program_source(boxes: list[OBB], program: ArticulationProgram,
                   mesh_files: dict[int, str] | None = None) -> str:
    """The script text; ``mesh_files`` maps box index to a mesh path relative to the script."""
    bboxes = "{\n" + "".join(f"    {i}: {_box_literal(b)},\n" for i, b in enumerate(boxes)) + "}"
    joints = ""
    for j in program.child_joints:
        parent = "" if j.parent is None else f", parent={j.parent}"
        joints += (f"    dict(box={j.box}, type={j.type!r}, idx={j.idx}, "
                   f"edge=[{j.edge[0]}, {j.edge[1]}], sign={j.sign}{parent}),\n")
    return _TEMPLATE.format(bboxes=bboxes, meshes=repr(dict(sorted((mesh_files or {}).items()))),
                            root=program.root_geom, joints=joints)
