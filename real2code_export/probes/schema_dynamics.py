"""What a USD or glTF export states of its dynamics in its own schema, read as the format's
consumers read it, not through our readers: per rigid body its mass, centre of mass and
inertia in the world at rest (hinges and slides at 0, balls at their rest, a free body where
the file puts it, as the kinematic probes pose them), the bodies welded to it (held by fixed
joints), and per joint what the schema holds of its law and range. ``check --reference``
compares them with the source's (``probes.dynamics.schema_differences``).

- USD: UsdPhysics' own parse (rigid bodies, joints, limits, colliders); PhysicsMassAPI's
  mass, centerOfMass, diagonalInertia and principalAxes (what PhysX reads); MjcJointAPI's
  damping, frictionloss, armature, stiffness and ref (MuJoCo's USD importer) and
  NewtonJointAPI's damping (per degree), friction and armature (Newton), each compared.
- glTF: KHR_physics_rigid_bodies' ``motion`` (mass, centerOfMass, inertiaDiagonal,
  inertiaOrientation), its joints' limits and force drives (stiffness, damping); friction
  and armature, for which the extension has no place, from our extras on the joint node.

A body whose mass or inertia the file leaves to the simulator (none stated, colliders to
compute it from) is *unstated*: its group is not equal to anything.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .. import transforms as tf
from ..inertia import combine_inertials
from ..model import UNBOUNDED_LIMIT, Inertial

WORLD = ""  # the world's group


@dataclass
class SchemaDynamics:
    """One export's dynamics as its schema states them (module docstring)."""

    file: str
    # body name -> (mass, inertia about its centre of mass in world axes, centre of mass)
    bodies: dict[str, tuple[float, np.ndarray, np.ndarray]] = field(default_factory=dict)
    unstated: dict[str, str] = field(default_factory=dict)  # body name -> what is left open
    group: dict[str, str] = field(default_factory=dict)  # body name -> its group's key
    # joint name -> (what, quantity, value): quantity is damping, frictionloss, armature,
    # stiffness, limited, range or ref, as MuJoCo names them; what says where it was read
    joints: dict[str, list[tuple[str, str, object]]] = field(default_factory=dict)
    # what the source's tool reads otherwise than the file states, not compared (said)
    left_out: list[str] = field(default_factory=list)
    # bodies whose inertia the source's tool makes up (a stand-in), not compared (said)
    stand_in_inertia: list[str] = field(default_factory=list)
    # body name -> its prim's path (a USD source's: what our reader's warnings name)
    paths: dict[str, str] = field(default_factory=dict)

    def group_inertias(self) -> dict[str, tuple[float, np.ndarray, np.ndarray] | str]:
        """Group key -> (mass, principal moments, centre of mass) of the bodies of the group,
        or what the file leaves open of them."""
        members: dict[str, list[str]] = {}
        for body, key in self.group.items():
            members.setdefault(key, []).append(body)
        return {key: self._inertia_of(bodies) for key, bodies in members.items()}

    def _inertia_of(self, bodies: list[str]) -> tuple[float, np.ndarray, np.ndarray] | str:
        open_ = [f"body {b!r}: {self.unstated[b]}" for b in bodies if b in self.unstated]
        if open_:
            return "; ".join(open_)
        massive = [self.bodies[b] for b in bodies if self.bodies[b][0] > 0.0]
        if not massive:
            return 0.0, np.zeros(3), np.zeros(3)
        total = combine_inertials([(Inertial(m, np.zeros(3), inertia), tf.make(translation=com))
                                   for m, inertia, com in massive])
        return total.mass, np.linalg.eigvalsh(total.inertia), total.com


def _union(pairs, items) -> dict:
    """Item -> the key of its connected group (``pairs`` connect two items): the world's
    group is keyed WORLD; any other group by one of its items."""
    parent = {i: i for i in items}
    parent.setdefault(WORLD, WORLD)

    def root(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for a, b in pairs:
        ra, rb = root(a), root(b)
        if ra == WORLD:  # (the world's root stays the root)
            ra, rb = rb, ra
        parent[ra] = rb
    return {i: root(i) for i in items}


# -- USD -----------------------------------------------------------------------------------
MJC = (("mjc:damping", "damping"), ("mjc:frictionloss", "frictionloss"),
       ("mjc:armature", "armature"), ("mjc:stiffness", "stiffness"))
NEWTON = (("newton:damping", "damping"), ("newton:friction", "frictionloss"),
          ("newton:armature", "armature"))


def _authored(prim, name: str) -> float:
    attr = prim.GetAttribute(name)
    value = attr.Get() if attr and attr.HasAuthoredValue() else None
    return 0.0 if value is None else float(value)  # (the importers' default)


def usd_dynamics(probe) -> SchemaDynamics:
    """A USD export's dynamics from the stage its probe (``probes.usd.UsdProbe``) opened."""
    from pxr import UsdPhysics

    stage, mpu = probe.stage, probe.meters_per_unit
    kpu = float(UsdPhysics.GetStageKilogramsPerUnit(stage))
    out = SchemaDynamics(str(probe.path))
    rigid, joints = {}, []
    for kind, (paths, descs) in probe.parsed.items():
        for p, d in zip(paths, descs, strict=True):
            if kind.name == "RigidBody":
                rigid[str(p)] = d
            elif kind.name.endswith("Joint"):
                joints.append((str(p), kind.name, d))
    poses = probe.body_poses(np.zeros((1, len(probe.joints))))
    names = {p: stage.GetPrimAtPath(p).GetName() for p in rigid}
    massless = []  # bodies with neither a mass nor a collider
    for path, desc in rigid.items():
        name = names[path]
        (mass, inertia, com), missing = _usd_mass(stage.GetPrimAtPath(path), kpu, mpu)
        if missing is not None and desc.collisions:  # a simulator computes it from them
            out.unstated[name] = (f"{missing} not stated (PhysicsMassAPI); a simulator "
                                  f"computes it from its {len(desc.collisions)} "
                                  "collider(s) at a density")
        elif missing == "mass":  # OpenUSD's mass computation fails on it: PhysX says 1 kg
            massless.append(name)
        # (a mass without a centre of mass or inertia, and no colliders: a point mass)
        pose = poses[path][0]
        out.bodies[name] = (mass, pose[:3, :3] @ inertia @ pose[:3, :3].T,
                            pose[:3, :3] @ com + pose[:3, 3])
    fixed = [(str(d.body0) if str(d.body0) in rigid else WORLD,
              str(d.body1) if str(d.body1) in rigid else WORLD)
             for _, kind, d in joints if kind == "FixedJoint"]
    out.group = {names[p]: (names[k] if k != WORLD else WORLD)
                 for p, k in _union(fixed, list(rigid)).items() if p != WORLD}
    for name in massless:  # (held by the world, its mass moves nothing)
        if out.group[name] != WORLD:
            out.unstated[name] = ("no mass stated (PhysicsMassAPI) and no collider: PhysX "
                                  "gives such a body 1 kg")
    for path, kind, d in joints:
        if kind == "D6Joint":  # a ball (free, or held at rest: formats.usd.d6) is one joint
            from ..formats.usd import d6

            dofs = d6.free_dofs(d, path, f"joint prim <{path}>")
            if dofs and d6.is_ball(dofs):
                out.joints[path.rsplit("/", 1)[-1]] = _usd_joint(
                    stage.GetPrimAtPath(path), "D6Joint", d, mpu, d6.is_held_ball(dofs))
            else:  # each free axis a joint (``<joint>_<axis>`` of several), as our reader
                for dof in dofs:  # splits it; the prim's law shared by its axes
                    name = path.rsplit("/", 1)[-1]
                    name = f"{name}_{dof.name}" if len(dofs) > 1 else name
                    to_model = math.radians if dof.angular else (lambda v: v * mpu)
                    bounds = None if dof.lower is None else (to_model(dof.lower),
                                                             to_model(dof.upper))
                    out.joints[name] = _joint_law(stage.GetPrimAtPath(path), dof.angular) + \
                        _range(f"limit:{dof.name}:physics:low, high", bounds)
        elif kind in ("RevoluteJoint", "PrismaticJoint", "SphericalJoint"):
            out.joints[path.rsplit("/", 1)[-1]] = _usd_joint(stage.GetPrimAtPath(path), kind,
                                                             d, mpu)
    return out


def _usd_mass(prim, kpu: float, mpu: float
              ) -> tuple[tuple[float, np.ndarray, np.ndarray], str | None]:
    """(mass, inertia about the centre of mass, centre of mass) in the body's frame in SI as
    PhysicsMassAPI states them, and which of them it leaves to the simulator (None: none).
    UsdPhysics' fallbacks mean "computed": mass 0, centre of mass -inf, diagonal inertia 0;
    what is left open reads as 0 (the origin, no inertia). Principal axes left at theirs
    (0, 0, 0, 0) beside a diagonal are the identity, as Newton's importer takes them."""
    from pxr import UsdPhysics

    from ..formats.usd.body import principal_axes

    api = UsdPhysics.MassAPI(prim) if prim.HasAPI(UsdPhysics.MassAPI) else None
    mass = max(float(api.GetMassAttr().Get() or 0.0), 0.0) * kpu if api else 0.0
    com = api.GetCenterOfMassAttr().Get() if api else None
    com = np.asarray(com, float) * mpu if com is not None and np.all(np.isfinite(com)) \
        else None
    diagonal = api.GetDiagonalInertiaAttr().Get() if api else None
    inertia = None
    if diagonal is not None and np.any(np.asarray(diagonal) > 0):
        turn = principal_axes(api)  # (left at its fallback: the identity, as Newton has it)
        inertia = turn @ np.diag(np.asarray(diagonal, float) * kpu * mpu * mpu) @ turn.T
    missing = "mass" if mass <= 0.0 else "centre of mass or inertia" \
        if com is None or inertia is None else None
    return (mass, np.zeros((3, 3)) if inertia is None else inertia,
            np.zeros(3) if com is None else com), missing


def _joint_law(prim, angular: bool) -> list[tuple[str, str, object]]:
    """A joint prim's MjcJointAPI and NewtonJointAPI values (NewtonJointAPI's damping per
    degree of a rotation made per radian)."""
    items: list[tuple[str, str, object]] = [(f"{q} ({a})", q, _authored(prim, a))
                                            for a, q in MJC]
    per_degree = math.pi / 180.0 if angular else 1.0
    return items + [(f"{q} ({a})", q, _authored(prim, a) / (per_degree if q == "damping"
                                                             else 1.0))
                    for a, q in NEWTON]


def _usd_joint(prim, kind: str, desc, mpu: float,
               held: bool = False) -> list[tuple[str, str, object]]:
    """What a joint prim states (``held``: a generic joint that is a ball held at rest)."""
    angular = kind != "PrismaticJoint"
    items = _joint_law(prim, angular)
    if kind == "D6Joint":  # a ball: its rotations limited to [0, 0] hold it, else free
        return items + _range("limit:rot*:physics:low, high", (0.0, 0.0) if held else None)
    if kind == "SphericalJoint":  # its cone: the smaller cone angle, as the reader keeps it
        lim = desc.limit
        cones = (float(lim.lower), float(lim.upper))
        limited = bool(lim.enabled) and all(math.isfinite(a) and a > 0.0 for a in cones)
        return items + _range("physics:coneAngle0Limit, coneAngle1Limit",
                              (0.0, math.radians(min(cones))) if limited else None)
    to_model = math.radians if angular else (lambda v: v * mpu)
    lim = desc.limit
    limited = bool(lim.enabled) and math.isfinite(lim.lower) and math.isfinite(lim.upper)
    bounds = (to_model(float(lim.lower)), to_model(float(lim.upper))) if limited else None
    items += _range("physics:lowerLimit, upperLimit", bounds)
    if prim.GetAttribute("mjc:ref").HasAuthoredValue():
        items.append(("ref (mjc:ref)", "ref", to_model(_authored(prim, "mjc:ref"))))
    return items


# -- glTF ----------------------------------------------------------------------------------
def gltf_dynamics(probe) -> SchemaDynamics:
    """A glb/gltf export's dynamics from the document its probe (``probes.gltf.GltfProbe``)
    read, posed by the probe's node tree."""
    from ..formats.gltf.conventions import EXTRAS_KEY, KHR_PHYSICS
    from ..formats.gltf.physics import free_axis

    doc = probe.document
    nodes = doc["nodes"]
    out = SchemaDynamics(str(probe.path))

    def khr(node) -> dict:
        ext = node.get("extensions") if isinstance(node.get("extensions"), dict) else {}
        value = ext.get(KHR_PHYSICS)
        return value if isinstance(value, dict) else {}

    moving = {i for i, n in enumerate(nodes) if "motion" in khr(n)}
    poses = probe.node_poses(np.zeros((1, len(probe.joints))))  # the scene's nodes
    owner: dict[int, str] = {}  # node -> the rigid body it moves with (WORLD: none)
    for i in poses:  # (parents before their children)
        if i in moving:
            owner[i] = str(i)
        for c in nodes[i].get("children") or []:
            owner[c] = owner.get(i, WORLD)
    owner.update((i, str(i)) for i in moving)  # (bodies in no scene too)

    def body_of(i: int | None) -> str:
        return owner.get(i, WORLD)

    name_of = {str(i): nodes[i].get("name") or f"node_{i}" for i in moving}
    for i in moving:
        motion, name = khr(nodes[i])["motion"], name_of[str(i)]
        missing = "mass" if "mass" not in motion else "inertia" \
            if "inertiaDiagonal" not in motion else None
        if missing is not None or i not in poses:
            out.unstated[name] = (f"motion states no {missing} (KHR_physics_rigid_bodies "
                                  "leaves it to the consumer)" if missing is not None else
                                  "a rigid body in no scene")
            out.bodies[name] = (0.0, np.zeros((3, 3)), np.zeros(3))
            continue
        pose = poses[i][0]
        x, y, z, w = motion.get("inertiaOrientation", [0.0, 0.0, 0.0, 1.0])
        turn = pose[:3, :3] @ tf.quat_to_matrix([w, x, y, z])
        inertia = turn @ np.diag(np.asarray(motion["inertiaDiagonal"], float)) @ turn.T
        com = pose[:3, :3] @ np.asarray(motion.get("centerOfMass", [0, 0, 0]), float) \
            + pose[:3, 3]
        out.bodies[name] = (float(motion["mass"]), inertia, com)
    described = khr(doc).get("physicsJoints") or []  # (the document's own extensions)
    extras = {}
    for n in nodes:
        data = (n.get("extras") or {}).get(EXTRAS_KEY) if isinstance(n.get("extras"), dict) \
            else None
        if isinstance(data, dict) and "joint" in data and "type" in data:
            extras[data["joint"]] = data
    fixed = []
    for i, n in enumerate(nodes):
        joint = khr(n).get("joint")
        if not isinstance(joint, dict) or not isinstance(joint.get("joint"), int) \
                or not 0 <= joint["joint"] < len(described):
            continue
        desc = described[joint["joint"]]
        axis = free_axis(desc)
        name = desc.get("name") or n.get("name") or f"node_{i}"
        # (every axis locked is a weld, or our ball held at its rest: its extras say which)
        held = axis is not None and axis.kind == "fixed" and \
            extras.get(name, {}).get("type") == "ball"
        if axis is not None and axis.kind == "fixed" and not held:
            fixed.append((body_of(i), body_of(joint.get("connectedNode"))))
            continue
        out.joints[name] = _gltf_joint(desc, None if held else axis, extras.get(name, {}))
    out.group = {name_of[b]: (name_of[k] if k != WORLD else WORLD)
                 for b, k in _union(fixed, list(name_of)).items() if b != WORLD}
    return out


def _gltf_joint(desc: dict, axis, extras: dict) -> list[tuple[str, str, object]]:
    """What a joint's description states (``axis``: its one free axis, None for a ball), and
    its friction and armature from our extras."""
    items: list[tuple[str, str, object]] = []
    for drive in desc.get("drives") or []:
        on_axis = axis is None or (drive.get("type") == axis.kind
                                   and int(drive.get("axis", -1)) == axis.axis)
        if on_axis and drive.get("mode", "force") == "force":
            items += [("damping (drive)", "damping", float(drive.get("damping", 0.0))),
                      ("stiffness (drive)", "stiffness", float(drive.get("stiffness", 0.0)))]
            break
    else:
        items += [("damping (drive)", "damping", 0.0), ("stiffness (drive)", "stiffness", 0.0)]
    law = extras.get("dynamics") or {}
    items += [("frictionloss (real2code extras)", "frictionloss", float(law.get("friction", 0.0))),
              ("armature (real2code extras)", "armature", float(law.get("armature", 0.0)))]
    if axis is not None:
        limited = axis.lower is not None and axis.upper is not None
        items += _range("limits", (axis.lower, axis.upper) if limited else None)
    else:  # a ball: its cone, a 2-D angular limit (every rotation locked: a cone of 0)
        cones = [float(lim["max"]) for lim in desc.get("limits") or []
                 if len(lim.get("angularAxes") or []) == 2 and "max" in lim] + [
            0.0 for lim in desc.get("limits") or []
            if sorted(lim.get("angularAxes") or []) == [0, 1, 2]
            and float(lim.get("min", -1)) == 0.0 and float(lim.get("max", 1)) == 0.0]
        items += _range("2-D angular limit", (0.0, min(cones)) if cones else None)
    return items


def _range(where: str, bounds: tuple[float, float] | None) -> list[tuple[str, str, object]]:
    """Whether a joint is limited, and its range: one at SDF's "no limit" (+-1e16, a URDF's
    unbounded rotor) is none, as ``probes.dynamics`` reads the source's."""
    if bounds is not None and all(abs(b) >= UNBOUNDED_LIMIT * (1.0 - 1e-6) for b in bounds):
        bounds = None
    out: list[tuple[str, str, object]] = [(f"limited ({where})", "limited", bounds is not None)]
    return out + ([(f"range ({where})", "range", bounds)] if bounds is not None else [])


# -- Newton's model of a USD source ----------------------------------------------------------
def newton_dynamics(path: str, answer: dict, as_urdf: bool = False) -> SchemaDynamics:
    """A USD source's dynamics as Newton's model holds them (``probes.newton``'s answer,
    SI, in the probe's frames at its configuration 0); ``as_urdf``: its bodies grouped as a
    URDF holds them (a ball joint fixed at its rest)."""
    out = SchemaDynamics(str(path))
    for name, body in answer["bodies"].items():
        out.bodies[name] = (float(body["mass"]), np.asarray(body["inertia"], float),
                            np.asarray(body["com"], float))
    out.group = dict(answer["group_as_urdf" if as_urdf else "group"])
    out.stand_in_inertia = list(answer.get("default_inertia", ()))
    out.paths = dict(answer.get("paths", {}))
    for name in answer.get("unit_bound", ()):
        out.unstated[name] = ("Newton computes its mass from its colliders at its default "
                              "density per cubic stage unit (it applies no metersPerUnit)")
    for name, joint in answer["joints"].items():
        unread = {u.split(" ")[0]: u for u in joint.get("unread", ())}
        items: list[tuple[str, str, object]] = [
            (f"{q} (Newton)", q, float(joint[q])) for q in ("damping", "frictionloss",
                                                            "armature") if q not in unread]
        out.left_out += [f"joint {name!r}: its {u}, which Newton's default importer does not "
                         "read" for u in unread.values()]
        bounds = tuple(joint["range"]) if joint["limited"] else None
        out.joints[name] = items + _range("Newton", bounds)
    return out
