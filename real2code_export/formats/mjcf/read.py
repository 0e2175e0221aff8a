"""MJCF -> ArticulatedObject. MuJoCo parses and compiles the file (defaults, classes, frames,
orientation notations, ``fromto`` are resolved by MuJoCo itself); the compiled mjModel is read.

One part per body: hinge -> revolute (limited) or continuous, slide -> prismatic, ball ->
ball, no joint -> fixed; a body with several hinges/slides/balls becomes a chain of massless
intermediate parts ``<body>_<joint>`` (given a negligible mass, warned). A free joint on a
top-level body is a floating joint from the root part ``world``. A site is a frame: a part
without mass or geometry, fixed to its body's part. A joint away from its
body origin moves the part frame to the joint (meshes and inertial follow); a joint ``ref``
moves it to the pose at qpos = 0, so joint values mean the same here and in MuJoCo. When the
world itself holds geoms or joints, several top-level bodies, or one placed away from the
origin (a robot standing on the floor), it becomes a root part ``world`` and the bodies hang
from it by fixed joints at their poses.

Colliding geoms are collision pieces (primitives become meshes); the visual is what MuJoCo
shows by default (groups 0-2), so a third-party geom that collides and shows serves as both,
while our own files keep their visual (group 2, non-colliding) and collision (group 3) apart.
"""

from __future__ import annotations

import functools
import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ... import transforms as tf
from ...errors import FormatError, ModelError, warn
from ...model import (
    DEFAULT_COLOR,
    RGBA,
    WHITE,
    ArticulatedObject,
    DriveLimits,
    Dynamics,
    Inertial,
    Joint,
    JointType,
    Limits,
    Mesh,
    Mimic,
    Part,
    sanitize_name,
    validate,
)
from ...mujoco_files import spec_from_file
from ...repairs import balanced_inertia, composed_mimic_chains, massless_moving_parts
from ...texture_atlas import Atlas
from .actuator import drive_of
from .conventions import (
    COLLISION_GROUP,
    KEYFRAME,
    METADATA,
    WORLD,
    describe_mujoco_error,
    parse_custom_name,
)
from .geometry import geom_mesh, give_meshes, pose
from .kept import ELEMENTS_KEY, merge_sections, unread_sections

_DEFAULT_GEOM_RGBA = (0.5, 0.5, 0.5, 1.0)  # MuJoCo's: the material's colour shows instead
_MUJOCO_DEFAULT_NAME = "MuJoCo Model"


def load(path: str | Path) -> ArticulatedObject:
    path = Path(path)
    if not path.is_file():
        raise FormatError(path, None, "file not found")
    spec, model, given = _compile(path)
    return _Reader(path, spec, model, given_meshes=given).read()


# -- parse and compile, errors named ------------------------------------------------------------
def _compile(path: Path):
    try:
        spec = spec_from_file(path)
    except ValueError as e:
        raise _error(path, str(e)) from e
    given = give_meshes(spec, {mesh: _mesh_file(spec, mesh, path)
                               for mesh in spec.meshes if mesh.file})
    if spec.compiler.fusestatic:  # a compile-time speed-up: the bodies stay as written
        spec.compiler.fusestatic = False
        warn(f"{path}: <compiler fusestatic='true'> (MuJoCo merges each body without joints "
             "into its parent when it compiles): read without it, such bodies kept as parts "
             "fixed to their parents, as the file writes them and the check compiles it; the "
             "MJCF export does not set it")
    if spec.compiler.discardvisual:  # MuJoCo's run-time saving: the file still holds them
        spec.compiler.discardvisual = False
        warn(f"{path}: <compiler discardvisual='true'> (MuJoCo drops the geoms that neither "
             "collide nor weigh when it compiles): read without it, the visual geoms kept; "
             "the MJCF export does not set it")
    try:
        model = _compiled_without_hulls(spec)
    except ValueError as e:
        missing = _missing_mesh(spec, path)
        if missing is not None:
            raise missing from e
        raise _error(path, str(e), spec) from e
    # (a mesh MuJoCo dropped, as discardvisual does, has no id)
    return spec, model, {mesh.id: (read, said) for mesh, read, said in given if mesh.id >= 0}


def _compiled_without_hulls(spec):
    """``spec.compile()``, without the convex hull (qhull) MuJoCo builds of every mesh a
    colliding geom uses, which nothing read here uses: the geoms compile with collisions
    off, their ``contype`` and ``conaffinity`` given back to the spec and the model after.
    Every body's mass, inertia and frame, every geom's and mesh's, compile the same
    (``tests/test_mjcf.py``; a mesh with ``inertia="convex"`` still gets its hull, for its
    mass); MuJoCo's hulls are about a quarter of a robot's compile (docs/benchmarks.md)."""
    colliding = [(geom, geom.contype, geom.conaffinity) for geom in spec.geoms
                 if geom.contype or geom.conaffinity]
    for geom, _, _ in colliding:
        geom.contype = geom.conaffinity = 0
    try:
        model = spec.compile()
    except ValueError:
        # What the compiler checks of the collisions themselves (a touch or tactile sensor
        # wants a colliding geom on its body) fails with them off: compiled as written.
        model = None
    finally:
        for geom, contype, conaffinity in colliding:
            geom.contype, geom.conaffinity = contype, conaffinity
    if model is None:
        return spec.compile()
    for geom, contype, conaffinity in colliding:
        if geom.id >= 0:  # (a geom MuJoCo dropped has no id)
            model.geom_contype[geom.id], model.geom_conaffinity[geom.id] = contype, conaffinity
    return model


def _error(path: Path, message: str, spec=None) -> FormatError:
    what, name, tag, line = describe_mujoco_error(message)
    if name and tag is None and spec is not None:  # "Element name 'lid'": which kind, where
        tag, found_line = _find_named(spec, name)
        line = line if line is not None else found_line
    if tag and name:
        element = f"<{tag} name='{name}'>"
    elif tag:
        element = f"<{tag}>"
    else:
        element = repr(name) if name is not None else None
    return FormatError(path, element, what, line)


def _find_named(spec, name: str) -> tuple[str | None, int | None]:
    for tag, elements in (("body", spec.bodies), ("joint", spec.joints), ("geom", spec.geoms),
                          ("mesh", spec.meshes)):
        for el in elements:
            if el.name == name:
                return tag, _info_line(el)
    return None, None


def _info_line(element) -> int | None:
    info = getattr(element, "info", "") or ""
    parts = info.split()
    # MuJoCo says "line 0" of an element it did not read from a file's text (an include's)
    line = int(parts[1]) if len(parts) == 2 and parts[0] == "line" and parts[1].isdigit() else 0
    return line or None


def _missing_mesh(spec, path: Path) -> FormatError | None:
    """A clear error for the usual compile failure: a mesh file that is not there."""
    for mesh in spec.meshes:
        if not mesh.file:
            continue
        candidate = _mesh_file(spec, mesh, path)
        if not candidate.is_file():
            return FormatError(path, f"<mesh name='{mesh.name}'>",
                               f"mesh file not found: {candidate}", _info_line(mesh))
    return None


def _mesh_file(spec, mesh, path: Path) -> Path:
    """Where MuJoCo looks for a mesh's file: ``meshdir`` (``assetdir``) under the model's
    folder unless absolute, the file under that unless absolute."""
    base = Path(spec.modelfiledir or path.parent)
    meshdir = Path(spec.meshdir or "")
    file = Path(mesh.file)
    return file if file.is_absolute() else (
        meshdir / file if meshdir.is_absolute() else base / meshdir / file)


# -- the compiled model -> the object -----------------------------------------------------------
@dataclass
class _Reader:
    path: Path
    spec: object
    model: object
    part_names: dict[int, str] = field(default_factory=dict)  # body id -> part name
    frames: dict[int, np.ndarray] = field(default_factory=dict)  # body id -> part-from-body
    custom: dict[tuple[str, str], object] = field(default_factory=dict)
    spec_bodies: dict[int, object] = field(default_factory=dict)  # model id -> spec element
    spec_joints: dict[int, object] = field(default_factory=dict)
    mesh_assets: dict[int, tuple[Mesh, np.ndarray]] = field(default_factory=dict)  # read once
    given_meshes: dict[int, tuple[Mesh, list]] = field(default_factory=dict)  # see give_meshes
    notes: dict[str, list[str]] = field(default_factory=dict)
    taken_parts: set[str] = field(default_factory=set)
    joint_of: dict[int, Joint] = field(default_factory=dict)  # MuJoCo joint id -> model joint
    mimics: set[tuple[str, str]] = field(default_factory=set)  # (joint1, joint2) in the file
    drives: dict[int, str] = field(default_factory=dict)  # actuator id -> the joint it drives
    renamed: dict[str, set[str]] = field(default_factory=dict)  # file name -> model name(s)

    def read(self) -> ArticulatedObject:
        m = self.model
        self.spec_bodies = {int(b.id): b for b in self.spec.bodies}
        self.spec_joints = {int(j.id): j for j in self.spec.joints}
        self.custom = self._custom_data()
        taken = self.taken_parts
        for b in range(1, m.nbody):
            self.part_names[b] = self._name(m.body(b).name or f"body_{b}", taken, "body")
        top = [b for b in range(1, m.nbody) if int(m.body_parentid[b]) == 0]
        for b in range(1, m.nbody):
            self._check_joints(b, top_level=b in top)
        # The world is a part when it holds geoms, several bodies or a joint, or when the one
        # top-level body is placed away from it: the root part's frame must stay that body's.
        world_used = (m.body_geomnum[0] > 0 or len(top) != 1
                      or any(m.body_jntnum[b] for b in top)
                      or not np.array_equal(pose(m.body_pos[top[0]], m.body_quat[top[0]]),
                                            np.eye(4))
                      or (WORLD, "part") in self.custom)
        parts: list[Part] = []
        joints: list[Joint] = []
        joint_names: set[str] = set()
        if world_used:
            self.part_names[0] = sanitize_name(world_part_name(self.custom), taken)
            self.frames[0] = np.eye(4)
            parts.append(self._part(0))
        for b in range(1, m.nbody):
            if m.body_gravcomp[b]:  # a force MuJoCo applies, no law of the model's
                self.note("gravity compensation (gravcomp) not carried: the model has no "
                          "place for it", f"{self._body_label(b)} ({float(m.body_gravcomp[b]):g})")
            if m.body_mocapid[b] >= 0:  # moved by the user, not by the simulation
                self.note("mocap bodies read as parts fixed where they stand (the model has "
                          "no mocap bodies)", self._body_label(b))
            parent = int(m.body_parentid[b])
            body_pose = pose(m.body_pos[b], m.body_quat[b])
            if parent == 0 and not world_used:  # the root: its part frame is the world
                self.frames[b] = body_pose
                parts.append(self._part(b))
                continue
            joints += self._joints(b, parent, body_pose, joint_names, parts)
            parts.append(self._part(b))
        joints += self._sites(parts, joint_names, world_used, top[0] if top else 0)
        name = self._object_name()
        self._read_mimics()
        self._read_drives(joints)
        self._report_ignored()
        for kind, names in self.notes.items():
            warn(f"{self.path}: {kind}: {', '.join(names)}")
        obj = ArticulatedObject(name, parts, joints, self._metadata())
        renames = {raw: next(iter(new)) for raw, new in self.renamed.items()
                   if len(new) == 1 and raw not in new}  # one new name, none kept as it was
        moved = {m.body(b).name: frame for b, frame in self.frames.items()
                 if b and m.body(b).name and not np.array_equal(frame, np.eye(4))}
        moved_notes: list[str] = []
        markers = self._drive_markers(joints)  # (else every actuator is a drive, in order)
        kept = unread_sections(self.path, self.mimics, renames, moved, moved_notes,
                               self.drives, markers) \
            if self._has_unread() or markers else {}
        for note in moved_notes:
            warn(f"{self.path}: kept element {note}")
        left = obj.metadata.get(ELEMENTS_KEY)  # what a writer of ours could not write back
        if isinstance(left, dict) and all(isinstance(v, str) for v in left.values()):
            kept = merge_sections(kept, left)
        if kept:
            obj.metadata[ELEMENTS_KEY] = kept
        for joint_name, message in composed_mimic_chains(obj) + massless_moving_parts(obj):
            warn(f"{self.path}: joint {joint_name!r}: {message}")
        try:
            return validate(obj)
        except ModelError as e:
            raise FormatError(self.path, e.element, e.message) from e

    def note(self, kind: str, name: str) -> None:
        self.notes.setdefault(kind, []).append(name)

    def _name(self, raw: str, taken: set[str], what: str) -> str:
        name = sanitize_name(raw, taken)
        if name != raw:
            self.note(f"{what} names changed to identifiers", f"{raw!r} -> {name!r}")
            if what in ("body", "joint", "site"):  # what kept elements refer to
                self.renamed.setdefault(raw, set()).add(name)
        else:
            self.renamed.setdefault(raw, set()).add(raw)  # (another kind kept the name)
        return name

    def _object_name(self) -> str:
        raw = self.spec.modelname
        if not raw or raw == _MUJOCO_DEFAULT_NAME:
            raw = self.path.stem
        return self._name(raw, set(), "model")

    def _body_label(self, b: int) -> str:
        name = self.model.body(b).name
        return f"<body name='{name}'>" if name else f"<body> (unnamed, id {b})"

    # -- joints ----------------------------------------------------------------------------
    def _check_joints(self, b: int, *, top_level: bool) -> None:
        # MuJoCo itself refuses a free joint below the top level or beside another joint.
        if self._free_joint(b) is not None and not top_level:
            raise FormatError(self.path, self._body_label(b), "has a free joint below the top "
                              "level", _info_line(self.spec_bodies[b]))

    def _free_joint(self, b: int) -> int | None:
        import mujoco

        m = self.model
        first = int(m.body_jntadr[b])
        return next((j for j in range(first, first + int(m.body_jntnum[b]))
                     if int(m.jnt_type[j]) == mujoco.mjtJoint.mjJNT_FREE), None)

    def _joints(self, b: int, parent: int, body_pose: np.ndarray, taken: set[str],
                parts: list[Part]) -> list[Joint]:
        """The joints that place body ``b``: one, or for a body with several joints a chain
        through intermediate parts ``<body>_<joint>`` (massless; MuJoCo applies a body's
        joints in order, each about its anchor in the frame the previous ones moved)."""
        m = self.model
        child = self.part_names[b]
        parent_name = self.part_names[parent]
        base = self.frames[parent] @ body_pose
        free = self._free_joint(b)
        if free is not None:  # a top-level body: its pose in the world is its qpos0
            self.frames[b] = np.eye(4)
            return [self._joint(free, parent_name, child, base, taken)]
        first = int(m.body_jntadr[b])
        movable = list(range(first, first + int(m.body_jntnum[b])))
        if not movable:
            self.frames[b] = np.eye(4)
            raw = self.custom.get((m.body(b).name, "parent_joint"))
            name = self._name(raw, taken, "joint") if isinstance(raw, str) else sanitize_name(
                f"{parent_name}_to_{child}", taken)
            return [Joint(name, JointType.FIXED, parent_name, child, origin=base)]
        joints, previous = [], np.zeros(3)
        for k, j in enumerate(movable):
            last = k == len(movable) - 1
            link = child if last else sanitize_name(
                f"{child}_{m.joint(j).name or f'joint_{k}'}", self.taken_parts)
            start = base if k == 0 else tf.make(translation=-previous)
            joints.append(self._joint(j, parent_name, link, start, taken))
            if not last:
                parts.append(Part(link))
            if k == 0 and len(movable) > 1:
                self.note("bodies with several joints split into a chain of massless parts",
                          f"{child} ({len(movable)} joints)")
            parent_name, previous = link, np.asarray(m.jnt_pos[j], dtype=np.float64)
        self.frames[b] = tf.make(translation=-previous) if previous.any() else np.eye(4)
        return joints

    def _joint(self, j: int, parent_name: str, child: str, base: np.ndarray,
               taken: set[str]) -> Joint:
        import mujoco

        m = self.model
        raw = m.joint(j).name
        name = self._name(raw, taken, "joint") if raw else sanitize_name(f"{child}_joint", taken)
        jtype = int(m.jnt_type[j])
        hinge = jtype == mujoco.mjtJoint.mjJNT_HINGE
        qadr, dof = int(m.jnt_qposadr[j]), int(m.jnt_dofadr[j])
        anchor = np.asarray(m.jnt_pos[j], dtype=np.float64)
        axis = np.asarray(m.jnt_axis[j], dtype=np.float64)
        limited = bool(m.jnt_limited[j])
        dynamics = Dynamics(
            damping=float(m.dof_damping[dof]), friction=float(m.dof_frictionloss[dof]),
            stiffness=float(m.jnt_stiffness[j]), armature=float(m.dof_armature[dof]))
        if jtype == mujoco.mjtJoint.mjJNT_FREE:  # qpos0 is the body's pose: the origin
            return Joint(name, JointType.FLOATING, parent_name, child, origin=base,
                         dynamics=dynamics)
        if jtype == mujoco.mjtJoint.mjJNT_BALL:  # qpos0 is the identity rotation
            # a limited ball's range is [0, the largest rotation] (MuJoCo refuses another)
            return Joint(name, JointType.BALL, parent_name, child,
                         origin=base @ tf.make(translation=anchor), dynamics=dynamics,
                         cone_limit=float(m.jnt_range[j][1]) if limited else None)
        ref = float(m.qpos0[qadr])
        if hinge:
            kind = JointType.REVOLUTE if limited else JointType.CONTINUOUS
        else:  # a slide without a range slides freely (limits None)
            kind = JointType.PRISMATIC
        joint = Joint(name, kind, parent_name, child, axis=axis)
        self.joint_of[j] = joint
        # Part frame = joint frame at qpos = 0: at the anchor, turned back by the reference.
        joint.origin = base @ tf.make(translation=anchor) @ joint.motion(-ref)
        joint.limits, joint.drive_limits = self._limits(j, kind, name)
        dynamics.spring_ref = float(m.qpos_spring[qadr])
        joint.dynamics = dynamics
        if np.any(m.dof_dampingpoly[dof]) or np.any(m.jnt_stiffnesspoly[j]):
            self.note("polynomial damping/stiffness terms dropped", name)
        joint.state = self._state(qadr, joint)
        return joint

    def _limits(self, j: int, kind: JointType,
                name: str) -> tuple[Limits | None, DriveLimits | None]:
        """(range with effort and velocity, or None; effort and velocity of a joint without a
        range, or None)."""
        m = self.model
        effort = self._custom_number(m.joint(j).name, "effort")
        if effort is None and m.jnt_actfrclimited[j]:
            low, high = (float(v) for v in m.jnt_actfrcrange[j])
            effort = max(-low, high, 0.0)
            if low != -high:
                self.note("asymmetric actuatorfrcrange kept as its larger magnitude", name)
        velocity = self._custom_number(m.joint(j).name, "velocity")
        effort = None if effort is None else float(effort)
        velocity = None if velocity is None else float(velocity)
        if kind is JointType.CONTINUOUS or not m.jnt_limited[j]:
            if effort is None and velocity is None:
                return None, None
            return None, DriveLimits(effort, velocity)
        low, high = (float(v) for v in m.jnt_range[j])
        return Limits(low, high, effort=effort, velocity=velocity), None

    def _custom_number(self, element: str, field_name: str) -> float | None:
        value = self.custom.get((element, field_name))
        if value is not None and not isinstance(value, float):
            self.note("malformed real2code custom data ignored", f"{element}:{field_name}")
            return None
        return value

    def _state(self, qadr: int, joint: Joint) -> float:
        import mujoco

        key = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_KEY, KEYFRAME)
        # Without our keyframe, the pose the file is written in (qpos0, the joint's ref).
        qpos = self.model.key_qpos[key] if key >= 0 else self.model.qpos0
        state = float(qpos[qadr])
        lim = joint.limits
        if lim is not None and not lim.lower <= state <= lim.upper:
            self.note("joint states outside the range moved to the nearest limit", joint.name)
            state = min(max(state, lim.lower), lim.upper)
        return state

    def _sites(self, parts: list[Part], taken: set[str], world_used: bool,
               root: int) -> list[Joint]:
        """Each site as a frame: a part with neither mass nor geometry, fixed to its body's
        part at the site's pose (an unnamed site named ``<body>_site_<k>``). A site of the
        world body, when the world is no part, hangs from the root part (the world frame)."""
        m = self.model
        joints = []
        for s in range(m.nsite):
            body = int(m.site_bodyid[s])
            raw = m.site(s).name or f"{m.body(body).name or f'body_{body}'}_site_{s}"
            name = self._name(raw, self.taken_parts, "site")
            at = pose(m.site_pos[s], m.site_quat[s])
            if body == 0 and not world_used:
                parent = self.part_names[root] if root else None
                if parent is None:
                    continue
            else:
                parent, at = self.part_names[body], self.frames[body] @ at
            colour = self.custom.get((raw, "color"))
            part = Part(name)
            if isinstance(colour, list) and len(colour) == 4:
                part.color = tuple(float(c) for c in colour)
            parts.append(part)
            kept = self.custom.get((raw, "parent_joint"))
            joint_name = self._name(kept, taken, "joint") if isinstance(kept, str) else \
                sanitize_name(f"{parent}_to_{name}", taken)
            joints.append(Joint(joint_name, JointType.FIXED, parent, name, origin=at))
        return joints

    # -- parts -----------------------------------------------------------------------------
    def _part(self, b: int) -> Part:
        m = self.model
        name = self.part_names[b]
        frame = self.frames[b]
        moved = not np.array_equal(frame, np.eye(4))
        shown, hidden, colliding = [], [], []
        for g in range(int(m.body_geomadr[b]), int(m.body_geomadr[b] + m.body_geomnum[b])):
            element = f"<geom name='{m.geom(g).name}'>" if m.geom(g).name else f"geom {g}"
            mesh = geom_mesh(m, g, self.path, element, self.mesh_assets, self.given_meshes)
            if mesh is None:
                self.note("geoms without a finite surface skipped (plane, hfield, sdf)",
                          f"{name}/{m.geom(g).name or g}")
                continue
            mesh = mesh.transformed(frame) if moved else mesh
            collides = bool(m.geom_contype[g] or m.geom_conaffinity[g])
            if collides:
                colliding.append((g, mesh))
            # The visual is what MuJoCo shows by default (groups 0-2): a third-party geom that
            # collides and shows serves as both. Hidden visual-only geoms count when nothing
            # else shows.
            if m.geom_group[g] < COLLISION_GROUP:
                shown.append((g, mesh))
            elif not collides:
                hidden.append((g, mesh))
        visual = shown or hidden
        colours = [self._rgba(g) for g, _ in visual + colliding]
        shown_colours = [tuple(float(c) for c in colours[k]) for k in range(len(visual))]
        colour = colours[0] if colours else self.custom.get((m.body(b).name, "color"))
        if colour is not None and (not isinstance(colour, list | tuple) or len(colour) != 4):
            self.note("malformed real2code custom data ignored", f"{m.body(b).name}:color")
            colour = None
        # several colours: kept per face, the part's the first run's unless we wrote its own
        visual_mesh = Mesh.concatenate([mesh for _, mesh in visual], shown_colours) \
            if visual else None
        if visual_mesh is not None and visual_mesh.colors:
            colour = self.custom.get((m.body(b).name, "color"), visual_mesh.colors[0][1])
        images = self._images(name, visual, visual_mesh, shown_colours)
        if isinstance(images, Atlas):
            self.note("images and colours of several geoms packed into one image (a part "
                      "holds one)" + (f": {'; '.join(images.notes)}" if images.notes else ""),
                      name)
            visual_mesh, colour, images = images.mesh, WHITE, {"texture": images.texture}
        return Part(
            name,
            visual=visual_mesh,
            collision=[mesh for _, mesh in colliding],
            inertial=self._inertial(b, frame, moved),
            color=tuple(float(c) for c in colour) if colour is not None else DEFAULT_COLOR,
            **_part_images(images),
        )

    def _images(self, name: str, visual: list[tuple[int, Mesh]], joined: Mesh | None,
                colours: list[RGBA]) -> dict | Atlas:
        """The visual geoms' material images by the model's roles ("texture" for MuJoCo's RGB
        layer; normal, occlusion, emissive; ORM as glTF's metallic-roughness map, its R the
        occlusion), read from the files MuJoCo loaded, where the mesh has the texture
        coordinates to place them. Geoms with colour images only, of several images or
        beside geoms of other colours, give one image (:mod:`...texture_atlas`). Separate
        roughness or metallic layers are not kept."""
        import mujoco

        from ...meshfiles import texture_from_file
        from ...texture_atlas import AtlasPiece, needs_atlas, pack  # (Pillow on demand)

        geoms = [g for g, _ in visual]

        role = mujoco.mjtTextureRole
        roles = {"texture": role.mjTEXROLE_RGB, "normal": role.mjTEXROLE_NORMAL,
                 "occlusion": role.mjTEXROLE_OCCLUSION, "emissive": role.mjTEXROLE_EMISSIVE,
                 "metallic_roughness": role.mjTEXROLE_ORM}
        m = self.model
        found: dict[str, list[Path]] = {}
        rgb_files: dict[int, Path] = {}  # geom -> its colour image
        for g in geoms:
            mat = int(m.geom_matid[g])
            if mat < 0:
                continue
            for ours, theirs in roles.items():
                tex = int(m.mat_texid[mat, theirs])
                if tex >= 0 and int(m.tex_pathadr[tex]) >= 0:
                    raw = bytes(m.paths[int(m.tex_pathadr[tex]):]).split(b"\0", 1)[0].decode()
                    found.setdefault(ours, []).append(self._texture_file(raw))
                    if ours == "texture":
                        rgb_files[g] = found[ours][-1]
            if any(int(m.mat_texid[mat, r]) >= 0
                   for r in (role.mjTEXROLE_ROUGHNESS, role.mjTEXROLE_METALLIC)):
                self.note("roughness and metallic layers not kept (the model holds them as "
                          "one packed image, MuJoCo's ORM)", name)
        if not found:
            return {}
        if set(found) == {"texture"} and all(f.is_file() for f in found["texture"]):
            images = {f: texture_from_file(f) for f in dict.fromkeys(found["texture"])}
            pieces = []
            for (g, mesh), colour in zip(visual, colours, strict=True):
                file = rgb_files.get(g)
                pieces.append(AtlasPiece(mesh, None if file is None else images[file], colour))
            if needs_atlas(pieces) and all(p.mesh.uv is not None for p in pieces if p.texture):
                return pack(pieces)
        if any(len(set(files)) > 1 or not files[0].is_file() for files in found.values()) \
                or joined is None or joined.uv is None:
            self.note("textures not kept (a part holds one material, on one mesh with texture "
                      "coordinates, from files)" + _unplaced_images(m, geoms), name)
            return {}
        return {ours: texture_from_file(files[0]) for ours, files in found.items()}

    def _texture_file(self, raw: str) -> Path:
        """A texture's file as MuJoCo finds it: absolute, or under texturedir, which is
        relative to the model file's folder."""
        file = Path(raw)
        if file.is_absolute():
            return file
        texturedir = Path(self.spec.texturedir or "")
        if texturedir.is_absolute():
            return texturedir / file
        return Path(self.spec.modelfiledir or self.path.parent) / texturedir / file

    def _rgba(self, g: int) -> tuple[float, ...]:
        m = self.model
        rgba = tuple(float(c) for c in m.geom_rgba[g])
        mat = int(m.geom_matid[g])
        if mat >= 0 and tf.allclose_to_finite(rgba, _DEFAULT_GEOM_RGBA):
            rgba = tuple(float(c) for c in m.mat_rgba[mat])
        return tuple(min(max(c, 0.0), 1.0) for c in rgba)

    def _inertial(self, b: int, frame: np.ndarray, moved: bool) -> Inertial | None:
        m = self.model
        if b == 0:
            return _world_inertial(self.custom.get((WORLD, "inertial")))
        mass = float(m.body_mass[b])
        if not mass > 0:
            return None
        com = np.asarray(m.body_ipos[b], dtype=np.float64)
        inertia = self._inertia_tensor(b)
        if moved:
            rot = frame[:3, :3]
            com = rot @ com + frame[:3, 3]
            inertia = rot @ inertia @ rot.T
        # MuJoCo accepts a zero or degenerate tensor on a body that does not move.
        inertial, change = balanced_inertia(Inertial(mass, com, inertia))
        if change is not None:
            line = _info_line(self.spec_bodies[b])
            where = f"{self.path}:{line}" if line is not None else str(self.path)
            warn(f"{where}: {self._body_label(b)}: {change}")
        return inertial

    def _inertia_tensor(self, b: int) -> np.ndarray:
        import mujoco

        m = self.model
        rot = tf.quat_to_matrix(m.body_iquat[b])
        compiled = rot @ np.diag(m.body_inertia[b]) @ rot.T
        body = self.spec_bodies[b]
        full = np.asarray(body.fullinertia, dtype=np.float64)
        from_geoms = self.spec.compiler.inertiafromgeom == mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_TRUE
        if from_geoms or not body.explicitinertial or not np.all(np.isfinite(full)):
            return compiled
        # A fullinertia as written is exact; MuJoCo's diagonalisation changes the last bits.
        authored = np.array([[full[0], full[3], full[4]], [full[3], full[1], full[5]],
                             [full[4], full[5], full[2]]])
        scale = max(float(np.abs(compiled).max()), 1e-300)
        return authored if np.allclose(authored, compiled, rtol=0.0, atol=1e-9 * scale) else compiled

    # -- custom data, metadata, what is left out -------------------------------------------
    def _custom_data(self) -> dict[tuple[str, str], object]:
        import mujoco

        m = self.model
        out: dict[tuple[str, str], object] = {}
        for i in range(m.nnumeric):
            key = parse_custom_name(m.numeric(i).name)
            if key is None:
                self.note("custom numeric data not imported", m.numeric(i).name)
                continue
            adr, size = int(m.numeric_adr[i]), int(m.numeric_size[i])
            values = [float(v) for v in m.numeric_data[adr:adr + size]]
            out[key] = values[0] if len(values) == 1 else values
        for i in range(m.ntext):
            name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_TEXT, i) or ""
            adr, size = int(m.text_adr[i]), int(m.text_size[i])
            text = bytes(m.text_data[adr:adr + size]).split(b"\0", 1)[0].decode("utf-8")
            if name == METADATA:
                out[("", "metadata")] = text
            elif (key := parse_custom_name(name)) is not None:
                out[key] = text
            else:
                self.note("custom text data not imported", name)
        return out

    def _metadata(self) -> dict:
        text = self.custom.get(("", "metadata"))
        if text is None:
            return {}
        try:
            data = json.loads(text)
        except json.JSONDecodeError as e:
            warn(f"{self.path}: <text name='{METADATA}'>: not JSON ({e.msg}); metadata ignored")
            return {}
        if not isinstance(data, dict):
            warn(f"{self.path}: <text name='{METADATA}'>: not a JSON object; metadata ignored")
            return {}
        return data

    def _read_mimics(self) -> None:
        """Joint equality constraints that couple one hinge/slide to another linearly (MuJoCo:
        y - y0 = a0 + a1 (x - x0), y0 and x0 the joints' qpos0) as the follower's mimic:
        q_y = a1 q_x + (y0 + a0 - a1 x0). Others stay unread (warned with the rest)."""
        import mujoco

        m = self.model
        for e in range(m.neq):
            follower = self.joint_of.get(int(m.eq_obj1id[e]))
            leader = self.joint_of.get(int(m.eq_obj2id[e]))
            a0, a1, *higher = (float(v) for v in m.eq_data[e][:5])
            if (int(m.eq_type[e]) != mujoco.mjtEq.mjEQ_JOINT or not m.eq_active0[e]
                    or follower is None or leader is None or any(higher)
                    or follower.mimic is not None):
                continue
            y0 = float(m.qpos0[m.jnt_qposadr[int(m.eq_obj1id[e])]])
            x0 = float(m.qpos0[m.jnt_qposadr[int(m.eq_obj2id[e])]])
            follower.mimic = Mimic(leader.name, a1, y0 + a0 - a1 * x0)
            self.mimics.add((m.joint(int(m.eq_obj1id[e])).name, m.joint(int(m.eq_obj2id[e])).name))

    def _read_drives(self, joints: list[Joint]) -> None:
        """Actuators that are a drive of one joint (:mod:`.actuator`) as that joint's drive,
        the first on a joint; the others stay kept (warned with them, by why)."""
        m = self.model
        for i in range(m.nu):
            drive, why = drive_of(m, i)
            joint = self.joint_of.get(int(m.actuator_trnid[i, 0])) if drive else None
            if drive is not None and joint is None:
                drive, why = None, "on a joint the model holds otherwise"
            if drive is not None and joint.drive is not None:
                drive, why = None, "a second actuator on the joint"
            if drive is None:
                label = m.actuator(i).name or f"id {i}"
                self.note("actuators kept as MJCF, not drives of the model (no other format "
                          "acts on them)", f"{label!r} ({why})")
                continue
            target = self._custom_number(joint.name, "drive_target")  # (MuJoCo's ctrl: 0)
            drive.target = 0.0 if target is None else target
            joint.drive = drive
            self.drives[i] = joint.name

    def _drive_markers(self, joints: list[Joint]) -> bool:
        """Whether the kept actuators need markers where the drives stood: some stay kept,
        or the drives' order is not their joints' (the order the writer writes them in)."""
        order = {j.name: k for k, j in enumerate(joints)}
        places = [order[name] for _, name in sorted(self.drives.items())]
        return len(self.drives) < self.model.nu or places != sorted(places)

    def _report_ignored(self) -> None:
        import mujoco

        m = self.model
        observed = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_KEY, KEYFRAME) >= 0

        def listed(counts: dict[str, int]) -> str:
            """``{"sensor": 2, "geom (a note)": 1}`` -> "2 sensors, 1 geom (a note)"."""
            def counted(what: str, n: int) -> str:
                noun, note = what.split(" (", 1) if " (" in what else (what, "")
                return f"{n} {noun}{'s' if n > 1 else ''}" + (f" ({note}" if note else "")
            return ", ".join(counted(what, n) for what, n in counts.items() if n)

        kept = listed(self._unread_counts())
        if kept:
            warn(f"{self.path}: MJCF elements with no place in the model kept as metadata "
                 f"{ELEMENTS_KEY!r} (the MJCF writer writes them back; no other format acts "
                 f"on them): {kept}")
        left = listed({"keyframe": m.nkey - int(observed), "flex": m.nflex, "skin": m.nskin,
                       "custom tuple": m.ntuple, "camera": m.ncam, "light": m.nlight,
                       "contact pair": m.npair,
                       "contact exclusion (of bodies not joined)": _unjoined_exclusions(m),
                       "collision geom (its own friction, condim, solref, solimp, margin, "
                       "gap, priority or solmix: the model has no contact material)":
                       _own_contact(m),
                       "joint (its own limit or friction softness: solreflimit, solimplimit, "
                       "margin, solreffriction or solimpfriction; the exports write the "
                       "engines' common one, engine_settings)": _own_softness(m)})
        if left:
            warn(f"{self.path}: MJCF elements with no place in the model were not imported: "
                 f"{left}")
        options = _own_options(m)
        if options:
            warn(f"{self.path}: <option> settings not carried (the model holds no simulation "
                 f"options; every export leaves its tool's defaults): {', '.join(options)}")

    def _unread_counts(self) -> dict[str, int]:
        m = self.model
        return {"actuator": m.nu - len(self.drives), "tendon": m.ntendon,
                "equality constraint": m.neq - len(self.mimics), "sensor": m.nsensor}

    def _has_unread(self) -> bool:
        return any(self._unread_counts().values())


def _unjoined_exclusions(m) -> int:
    """The file's ``<exclude>`` pairs other than of a body and its parent (the exports
    exclude those themselves)."""
    first, second = m.exclude_signature >> 16, m.exclude_signature & 0xFFFF
    return int(np.sum((m.body_parentid[second] != first) & (m.body_parentid[first] != second)))


def _own_options(m) -> list[str]:
    """The model's ``<option>`` values that are not MuJoCo's defaults, as ``name=value``
    (flags as MJCF writes them: ``flag gravity=disable``)."""
    import mujoco

    default = _defaults().opt
    enums = {"integrator": mujoco.mjtIntegrator, "cone": mujoco.mjtCone,
             "jacobian": mujoco.mjtJacobian, "solver": mujoco.mjtSolver}
    out = []
    for name in dir(default):
        value = getattr(m.opt, name)
        if name.startswith("_") or callable(value) or \
                np.array_equal(np.asarray(value), np.asarray(getattr(default, name))):
            continue
        if name in ("disableflags", "enableflags"):  # as <flag NAME="enable|disable"/>
            bits = (mujoco.mjtDisableBit if name == "disableflags" else mujoco.mjtEnableBit)
            said = ("disable", "enable") if name == "disableflags" else ("enable", "disable")
            changed = int(value) ^ int(getattr(default, name))
            out += [f"flag {key.split('_', 1)[1].lower()}="
                    f"{said[0] if int(value) & int(bit) else said[1]}"
                    for key, bit in bits.__members__.items()
                    if not key.startswith("mjN") and changed & int(bit)]  # (mjN...: a count)
        elif name in enums:  # by the keyword MJCF writes
            keyword = next((k for k, v in enums[name].__members__.items() if int(v) == value),
                           str(value))
            out.append(f"{name}={keyword.split('_', 1)[-1].lower()}")
        else:
            out.append(f"{name}={' '.join(f'{v:g}' for v in np.atleast_1d(value))}")
    return out


@functools.cache
def _defaults():
    """A model of one body with one joint and one geom, each with MuJoCo's defaults (and
    its options); compiled once a process, every MJCF read compares with it."""
    import mujoco

    return mujoco.MjModel.from_xml_string(
        '<mujoco><worldbody><body><joint/><geom size="1"/></body></worldbody></mujoco>')


def _differ(values: np.ndarray, *allowed) -> np.ndarray:
    """Rows of ``values`` equal to none of ``allowed`` (each one row)."""
    rows = np.asarray(values, dtype=float)
    rows = rows.reshape(len(rows), -1) if rows.size else np.zeros((len(rows), 1))  # (no geoms)
    return np.all([np.any(np.abs(rows - np.ravel(a)) > 1e-12, axis=1) for a in allowed], axis=0)


def _own_contact(m) -> int:
    """Collision geoms whose contact parameters (friction, condim, solref, solimp, margin,
    gap, priority, solmix) are not MuJoCo's defaults."""
    d = _defaults()
    colliding = (m.geom_contype != 0) | (m.geom_conaffinity != 0)
    own = np.any([_differ(getattr(m, f), getattr(d, f)[0]) for f in
                  ("geom_friction", "geom_condim", "geom_solref", "geom_solimp", "geom_margin",
                   "geom_gap", "geom_priority", "geom_solmix")], axis=0)
    return int(np.sum(colliding & own))


def _own_softness(m) -> int:
    """Limited joints whose limit softness, and joints with dry friction whose friction
    softness, is neither MuJoCo's default nor the one the exports write (engine_settings)."""
    from ...engine_settings import FRICTION_SOLREF, LIMIT_MARGIN, LIMIT_SOLIMP, LIMIT_SOLREF

    if m.njnt == 0:
        return 0
    d = _defaults()
    limit = np.any([_differ(m.jnt_solref, d.jnt_solref[0], LIMIT_SOLREF),
                    _differ(m.jnt_solimp, d.jnt_solimp[0], LIMIT_SOLIMP),
                    _differ(m.jnt_margin, d.jnt_margin[0], LIMIT_MARGIN)], axis=0)
    friction = np.zeros(m.njnt, dtype=bool)
    rubbing = m.dof_frictionloss > 0
    own = _differ(m.dof_solref, d.dof_solref[0], FRICTION_SOLREF) | \
        _differ(m.dof_solimp, d.dof_solimp[0])
    friction[m.dof_jntid[rubbing & own]] = True
    return int(np.sum((limit & (m.jnt_limited != 0)) | friction))


def world_part_name(custom: dict) -> str:
    """The root part's name when it is the world body: ``world``, or the name our writer
    kept in <custom> (a floating base's root named otherwise)."""
    name = custom.get((WORLD, "name"))
    return name if isinstance(name, str) and name else WORLD


def _world_inertial(values) -> Inertial | None:
    """The inertial of a root part that was MuJoCo's world body (kept in <custom>)."""
    if not isinstance(values, list) or len(values) != 10:
        return None
    mass, cx, cy, cz, ixx, iyy, izz, ixy, ixz, iyz = values
    inertia = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
    return Inertial(mass, np.array([cx, cy, cz]), inertia)


def _unplaced_images(m, geoms: list[int]) -> str:
    """Why MuJoCo's placing of the geoms' colour images has no texture coordinates here:
    a 2D image on a mesh without its own is projected (:func:`.geometry.projected_uv`), but
    a cube texture is drawn by direction from the geom's centre, and a primitive (box,
    sphere, ...) has the renderer's own coordinates (a box: the whole image on each face)."""
    import mujoco

    reasons = set()
    for g in geoms:
        mat = int(m.geom_matid[g])
        tex = int(m.mat_texid[mat, mujoco.mjtTextureRole.mjTEXROLE_RGB]) if mat >= 0 else -1
        if tex < 0:
            continue
        if int(m.tex_type[tex]) != mujoco.mjtTexture.mjTEXTURE_2D:
            reasons.add("a cube texture, which MuJoCo draws by direction from the geom's "
                        "centre")
        elif int(m.geom_type[g]) != mujoco.mjtGeom.mjGEOM_MESH:
            reasons.add("an image on a primitive geom, which MuJoCo draws by the shape's own "
                        "coordinates (a box: the whole image on each face)")
    return f": {'; '.join(sorted(reasons))}" if reasons else ""


def _part_images(images: dict) -> dict:
    """A part's ``texture`` and ``maps`` fields from the images by role."""
    return {"texture": images.pop("texture", None), "maps": images}
