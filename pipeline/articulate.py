"""Part meshes in, articulated object out: Real2Code's "ground-truth boxes" setting.

Given one mesh per rigid part, all in one world frame with the object partly open, fit a
box per part, let a predictor write the articulation as code, turn its (box, axis, edge,
sign) choices into absolute joints, find the closed state and each joint's range, and
build the :class:`ArticulatedObject` whose exports at q = state reproduce the input poses.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from real2code_export import transforms as tf
from real2code_export.collision_separation import separate
from real2code_export.errors import InputError
from real2code_export.model import (
    ArticulatedObject,
    Joint,
    JointType,
    Limits,
    Mesh,
    Part,
    sanitize_name,
    validate,
)

from .closing import (
    SCAN_STOP_SHARE,
    front_plane,
    hinge_opening_from_mesh,
    hinge_upper,
    rotated_box,
    slide_clearance,
    slide_opening_from_mesh,
    slide_upper,
)
from .joint_code import ArticulationProgram, format_boxes, format_program, joint_axis_and_position
from .obb import OBB, aligned_boxes, part_obb
from .predictors import JointPredictor


@dataclass
class Articulation:
    """The object and what produced it (kept for inspection and evaluation)."""

    obj: ArticulatedObject
    boxes: list[OBB]
    part_names: list[str]
    program: ArticulationProgram
    prompt: str  # the box text a predictor reads
    code: str  # the program text it wrote


def articulate(meshes: dict[str, Mesh], predictor: JointPredictor, *, name: str = "object",
               colors: dict[str, tuple] | None = None, density: float | None = None,
               metadata: dict | None = None, collision: str = "auto",
               align_boxes: bool = False,
               observed: dict[str, np.ndarray | tuple[np.ndarray, np.ndarray]] | None = None,
               ) -> Articulation:
    """``collision``: "auto" (one convex piece per connected component of a part's mesh
    when it has a few, else its convex hull), "hull", or "coacd" (convex decomposition,
    tight but slow on large scans; cached by mesh hash). ``align_boxes``: refit the parts'
    boxes in the largest part's frame (:func:`pipeline.obb.aligned_boxes`), for parts from a
    predicted segmentation, whose boxes a few wrong border points turn; exact meshes keep
    their own boxes (on the PartNet-Mobility holdout objects, whose largest part is not
    always the carcass, aligning exact parts raised the 6-15-part mean axis error from 19
    to 62 degrees). ``observed``: what each part was measured at (by the keys of
    ``meshes``: its points, or its points and their measured normals), from which the
    aligned boxes read their frames (completed meshes follow their completion grid's
    axes); given, the parts are a scan's, and a slide's stop must be a share of its
    surface meeting the parent (:func:`pipeline.closing.slide_clearance`)."""
    from real2code_export.inertia import DEFAULT_DENSITY, inertial_from_mesh

    if len(meshes) < 2:
        raise InputError(f"need at least two parts to articulate, got {len(meshes)}")
    taken: set[str] = set()
    names = [sanitize_name(n, taken) for n in meshes]
    world = dict(zip(names, meshes.values(), strict=True))
    clouds = [world[n].vertices for n in names]
    if align_boxes:
        seen = None if observed is None else [observed[k] for k in meshes]
        boxes = aligned_boxes(clouds, observed=seen)
    else:
        boxes = [part_obb(c) for c in clouds]
    program = predictor.predict(boxes)
    # a scan's hidden surfaces are guessed and its visible ones noisy: a slide's stop must
    # be a share of its surface meeting the parent, where exact meshes stop at first contact
    stop_share = 0.0 if observed is None else SCAN_STOP_SHARE
    sampled: dict[str, tuple[np.ndarray, np.ndarray]] = {}

    def surface(part: str) -> tuple[np.ndarray, np.ndarray]:
        if part not in sampled:
            sampled[part] = _surface_samples(world[part])
        return sampled[part]

    # World pose of every part at the observed state, parent first.
    pose = {names[program.root_geom]: np.eye(4)}
    joints: list[Joint] = []
    pending = list(program.child_joints)
    while pending:
        ready = [j for j in pending if names[program.parent_of(j)] in pose]
        if not ready:
            raise InputError("predicted joints do not form a tree")
        for cj in ready:
            pending.remove(cj)
            parent_name, child_name = names[program.parent_of(cj)], names[cj.box]
            parent_box, child_box = boxes[program.parent_of(cj)], boxes[cj.box]
            if cj.type == "hinge":
                hull, behind = _extremes(world[child_name]), surface(parent_name)[0]
                axis, point = joint_axis_and_position(child_box, cj.idx, cj.edge, cj.sign)
                others = [surface(n)[0] for n in names if n not in (parent_name, child_name)]
                state = hinge_opening_from_mesh(parent_box, hull, axis, point, behind, others)
                if state < 0:  # keep q = 0 closed and opening positive
                    axis, state = -axis, -state
                closed = rotated_box(child_box, axis, point, -state)
                upper = hinge_upper(parent_box, closed, axis, point, state)
                jtype, frame_point = JointType.REVOLUTE, point
            else:
                axis, point = joint_axis_and_position(child_box, cj.idx, cj.edge, cj.sign)
                samples, normals = surface(child_name)
                parent_mesh = world[parent_name]
                clearance = slide_clearance(parent_mesh.vertices, parent_mesh.faces, samples,
                                            normals, axis, stop_share)
                state = slide_opening_from_mesh(parent_box, samples, axis, clearance,
                                                surface(parent_name))
                closed = OBB(child_box.center - axis * state, child_box.R, child_box.extent)
                depth = front_plane(samples, axis) - float((samples @ axis).min())
                upper = slide_upper(depth, state)
                jtype, frame_point = JointType.PRISMATIC, closed.center
            parent_pose = pose[parent_name]
            closed_frame = tf.make(parent_pose[:3, :3], frame_point)  # parent's axes
            origin = tf.inverse(parent_pose) @ closed_frame
            joint = Joint(
                name=f"{child_name}_joint", type=jtype, parent=parent_name, child=child_name,
                origin=origin, axis=parent_pose[:3, :3].T @ axis,
                limits=Limits(0.0, float(upper)), state=float(state),
            )
            pose[child_name] = parent_pose @ joint.transform(state)
            joints.append(joint)

    parts = []
    for n in names:
        local = world[n].transformed(tf.inverse(pose[n]))
        parts.append(Part(
            name=n, visual=local, collision=_collision(local, collision),
            inertial=inertial_from_mesh(local, density or DEFAULT_DENSITY),
            color=(colors or {}).get(n, (0.7, 0.7, 0.7, 1.0)),
        ))
    obj = ArticulatedObject(sanitize_name(name), parts, joints,
                            metadata={"articulated_by": predictor.name, **(metadata or {})})
    validate(obj)
    # Segmented parts interpenetrate a little; no engine should see them overlap.
    obj, _ = separate(obj)
    return Articulation(obj, boxes, names, program, format_boxes(boxes), format_program(program))


def _extremes(mesh: Mesh) -> np.ndarray:
    """The vertices of the mesh's convex hull: all a sweep that measures extremes needs."""
    from scipy.spatial import ConvexHull, QhullError

    v = np.asarray(mesh.vertices, dtype=float)
    try:
        return v[ConvexHull(v).vertices]
    except (QhullError, ValueError):  # flat or degenerate: joggle, else every vertex
        try:
            return v[ConvexHull(v, qhull_options="QJ").vertices]
        except (QhullError, ValueError):
            return v


SURFACE_SAMPLES = 20000


def _surface_samples(mesh: Mesh) -> tuple[np.ndarray, np.ndarray]:
    """Points spread evenly over the surface and their faces' normals (seeded: articulation
    is deterministic)."""
    import trimesh

    tm = mesh.to_trimesh()
    points, faces = trimesh.sample.sample_surface(tm, SURFACE_SAMPLES, seed=0)
    return np.asarray(points), np.asarray(tm.face_normals[faces])


MAX_COMPONENT_PIECES = 64


def _collision(mesh: Mesh, method: str) -> list[Mesh]:
    import trimesh

    from real2code_export.collision import collision_pieces

    if method != "auto":
        return collision_pieces(mesh, method)
    tm = mesh.to_trimesh()
    labels = trimesh.graph.connected_component_labels(tm.face_adjacency, node_count=len(tm.faces))
    n_components = int(labels.max()) + 1 if len(labels) else 0
    if 1 < n_components <= MAX_COMPONENT_PIECES:
        pieces = [Mesh.from_trimesh(p) for p in tm.split(only_watertight=False)]
        return collision_pieces(mesh, "pieces", source_pieces=pieces)
    return collision_pieces(mesh, "hull")
