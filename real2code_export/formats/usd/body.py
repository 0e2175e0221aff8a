"""Rigid bodies and mass: one Xform per part with PhysicsRigidBodyAPI, placed in the world
(translate + orient in double precision), and PhysicsMassAPI (mass, centerOfMass,
diagonalInertia + principalAxes from the principal decomposition). NewtonMassAPI's
``newton:inertia`` (the full tensor, double precision, body frame) is written too: Newton
reads it in place of the principal form, and our importer uses it to stay exact.
PhysxRigidBodyAPI's link damping is written as 0 (PhysX's default is not).
"""

from __future__ import annotations

import numpy as np

from ... import transforms as tf
from ...engine_settings import LINK_DAMPING
from ...errors import warn
from ...model import ArticulatedObject, Inertial, JointType, Mesh, Part
from .conventions import as_float32, quatf
from .layer import apply, attribute, define, place

PHYSX_RIGID_BODY = "PhysxRigidBodyAPI"
PHYSX_LINK_DAMPING = ("physxRigidBody:linearDamping", "physxRigidBody:angularDamping")


def write_body(layer, path: str, part: Part, world: np.ndarray):
    prim = define(layer, path, "Xform", "PhysicsRigidBodyAPI")
    place(prim, world)
    # PhysX damps every body it is not told otherwise about (angular 0.05): our parts move
    # by their joint laws alone. Codeless: usd-core has no PhysxSchema, the tokens suffice.
    apply(prim, PHYSX_RIGID_BODY)
    for name in PHYSX_LINK_DAMPING:
        attribute(prim, name, "Float", LINK_DAMPING)
    if part.inertial is not None:
        write_mass(prim, part.inertial)
    return prim


def write_mass(prim, inertial: Inertial) -> None:
    """A body's PhysicsMassAPI (and NewtonMassAPI's full tensor) in its frame."""
    from pxr import Gf

    apply(prim, "PhysicsMassAPI")
    attribute(prim, "physics:mass", "Float", as_float32(inertial.mass))
    attribute(prim, "physics:centerOfMass", "Point3f", Gf.Vec3f(*inertial.com.tolist()))
    moments, axes = inertial.principal()
    attribute(prim, "physics:diagonalInertia", "Float3", Gf.Vec3f(*moments.tolist()))
    attribute(prim, "physics:principalAxes", "Quatf", quatf(axes))
    apply(prim, "NewtonMassAPI")
    attribute(prim, "newton:inertia", "DoubleArray", _six(inertial.inertia))


def _six(i: np.ndarray) -> list[float]:  # xx yy zz xy xz yz
    return [float(i[0, 0]), float(i[1, 1]), float(i[2, 2]), float(i[0, 1]), float(i[0, 2]),
            float(i[1, 2])]


def in_parent_body(obj: ArticulatedObject, generic: set[str] = frozenset()) -> list[str]:
    """The parts written as an Xform in their parent's body (or in such an Xform), parents
    first: fixed, massless or carried (:func:`inertia.carrier`: welded under a moving part
    with no mass of its own, whose body then states their summed mass,
    :func:`carry_welded_mass`), whatever hangs from them (a frame; a link with only
    geometry; a chain of them, as Unitree's collision-only calf links; the body welded under
    a massless free body, as MJCF writes a free object; a URDF arm's massless flange link
    the hand hangs from). Their geometry is the body's in every simulator; the Xform keeps
    their name, frame, look and own mass for the round trip. A joint hanging from such a
    part is written from the body holding it (:func:`hanging_pose`), as urdf-usd-converter
    writes it: as its own rigid body the part would state no mass, and PhysX gives such a
    body 1 kg. ``generic``: joints written as generic (D6) chains, whose first body must be
    a rigid body: a part they hang from stays one."""
    from ...inertia import carrier

    tree = obj.tree()

    def held(name: str) -> bool:  # fixed, no mass of its own; what hangs from it can be
        joint = tree.parent.get(name)
        return joint is not None and joint.type is JointType.FIXED \
            and (tree.parts[name].inertial is None or carrier(tree, name) is not None) \
            and all(held(j.child) or (j.type is not JointType.FLOATING
                                      and j.name not in generic)
                    for j in tree.children[name])

    inside = [j.child for j in obj.joints if held(j.child)]  # in the joints' order
    out: list[str] = []
    while inside:  # each after the frame it hangs from
        ready = [n for n in inside if tree.parent[n].parent not in inside]
        out += ready
        inside = [n for n in inside if n not in ready]
    return out


def hanging_pose(obj: ArticulatedObject, frames: list[str]) -> dict[str, tuple[str, np.ndarray]]:
    """Each part written as an Xform in a body (``frames``, parents first) -> the body's part
    and the part's pose in it."""
    tree = obj.tree()
    out: dict[str, tuple[str, np.ndarray]] = {}
    for name in frames:
        joint = tree.parent[name]
        body, pose = out.get(joint.parent, (joint.parent, np.eye(4)))
        out[name] = body, pose @ joint.origin
    return out


def carry_welded_mass(layer, obj: ArticulatedObject, frames: list[str],
                      path_of: dict[str, str]) -> None:
    """The bodies holding frames with mass (``frames``: the parts written as Xforms in
    their parent's body, parents first; ``path_of``: part -> its prim) state the summed mass
    properties of their own part and those frames in PhysicsMassAPI, the only mass PhysX
    and Newton read (a moving body with none gets a default of 1 kg); each of those prims
    keeps its part's own values in ``real2code:own*`` for our reader."""
    from ...inertia import combine_inertials

    tree = obj.tree()
    body_of = hanging_pose(obj, frames)  # frame -> its body part, its pose there
    held: dict[str, list[str]] = {}
    for name in frames:
        body = body_of[name][0]
        if tree.parts[name].inertial is not None:
            held.setdefault(body, []).append(name)
    for body, names in held.items():
        own = tree.parts[body].inertial
        pieces = [(tree.parts[n].inertial, body_of[n][1]) for n in names]
        prim = layer.GetPrimAtPath(path_of[body])
        write_mass(prim, combine_inertials(pieces + ([(own, np.eye(4))] if own else [])))
        for name in [body, *names]:
            write_own_mass(layer.GetPrimAtPath(path_of[name]), tree.parts[name].inertial)


def write_own_mass(prim, inertial: Inertial | None) -> None:
    """A part's own mass properties on its prim (:data:`.conventions.OWN_MASS`)."""
    from pxr import Gf

    from .conventions import OWN_CENTER_OF_MASS, OWN_INERTIA, OWN_MASS

    attribute(prim, OWN_MASS, "Double", 0.0 if inertial is None else inertial.mass,
              custom=True)
    if inertial is not None:
        attribute(prim, OWN_CENTER_OF_MASS, "Double3", Gf.Vec3d(*inertial.com.tolist()),
                  custom=True)
        attribute(prim, OWN_INERTIA, "DoubleArray", _six(inertial.inertia), custom=True)


def read_own_mass(prim, mpu: float, kpu: float) -> tuple[bool, Inertial | None]:
    """Whether ``prim`` states its part's own mass properties apart from its PhysicsMassAPI
    (:func:`write_own_mass`), and what they are (SI, the prim's frame: our frames and bodies
    are their parts' frames)."""
    from .conventions import OWN_CENTER_OF_MASS, OWN_INERTIA, OWN_MASS

    attr = prim.GetAttribute(OWN_MASS)
    if not attr or attr.Get() is None:
        return False, None
    mass = float(attr.Get()) * kpu
    if mass <= 0.0:
        return True, None
    com, tensor = prim.GetAttribute(OWN_CENTER_OF_MASS), prim.GetAttribute(OWN_INERTIA)
    if not com or com.Get() is None or not tensor or tensor.Get() is None \
            or len(tensor.Get()) != 6:
        return False, None  # not ours whole: PhysicsMassAPI's, as any reader takes it
    xx, yy, zz, xy, xz, yz = (float(v) * kpu * mpu * mpu for v in tensor.Get())
    return True, Inertial(mass, np.array(com.Get(), float) * mpu,
                          np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]]))


def write_frame(layer, path: str, joint):
    """A frame: an Xform in its parent's body at the fixed joint's origin (double precision),
    the joint's name in ``real2code:fixedJoint``."""
    from .conventions import FRAME_JOINT

    prim = define(layer, path, "Xform")
    place(prim, joint.origin)
    attribute(prim, FRAME_JOINT, "String", joint.name, custom=True)
    return prim


# kg/m^3: what a UsdPhysics simulator gives a collider whose density nothing authors (PhysX's
# default, Newton's ShapeConfig.density)
SIMULATOR_DENSITY = 1000.0
# what the warning of a mass computed as the simulators compute it says (no repair: it
# explains no difference with Newton's model, ``probes.dynamics.NEWTON_RULES``)
SIMULATORS_RULE = "as PhysX and Newton compute it"


def read_inertial(prim, to_part: np.ndarray, meshes: list[Mesh], mpu: float, kpu: float,
                  where: str, colliders: list[Mesh] | None = None,
                  scale: np.ndarray | None = None,
                  collider_mass: list[tuple[float, float]] | None = None) -> Inertial | None:
    """The part's inertial in the part frame, SI units. ``to_part`` maps body -> part frame
    (metres); ``meshes`` (part frame) are used only to fill what the file leaves to the
    simulator to compute (a warning says so). A rigid body with no mass authored has the
    mass its ``colliders`` (part frame) give it at the authored density, else
    :data:`SIMULATOR_DENSITY`, as the simulators compute it (warned); ``collider_mass``, one
    (mass kg, density kg/m^3) per collider, 0 where not authored: a collider's own
    PhysicsMassAPI (UsdPhysics sums the colliders, each at its own mass or density, the
    body's density, else the default). ``scale``: a scaled
    body's own scale (:func:`.read._rigid_and_scale`): its authored centre of mass is in its
    scaled local space, so scaled with it, as Newton's importer and OpenUSD's descriptors
    take it (its inertia is as authored)."""
    from pxr import UsdPhysics

    if not prim.HasAPI(UsdPhysics.MassAPI):
        return _from_colliders(prim, colliders or [], mpu, kpu, where, collider_mass)
    api = UsdPhysics.MassAPI(prim)
    mass = float(api.GetMassAttr().Get() or 0.0) * kpu
    if mass <= 0.0:
        if colliders:
            return _at_authored_com(
                _from_colliders(prim, colliders, mpu, kpu, where, collider_mass), api,
                to_part, mpu, scale)
        warn(f"{where}: mass not authored (the simulator would compute it from density); "
             "the part gets no inertial")
        return None
    com = api.GetCenterOfMassAttr().Get()
    com = None if com is None or not np.all(np.isfinite(com)) else np.array(com, float) * mpu
    if com is not None and scale is not None:
        com = com * scale
    tensor = prim.GetAttribute("newton:inertia").Get() if prim.HasAttribute("newton:inertia") \
        else None
    inertia = None
    if tensor is not None and len(tensor) == 6:
        xx, yy, zz, xy, xz, yz = (float(v) for v in tensor)
        inertia = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
    else:
        diagonal = api.GetDiagonalInertiaAttr().Get()
        if diagonal is not None and np.any(np.asarray(diagonal) > 0):
            r = principal_axes(api)
            inertia = r @ np.diag(np.asarray(diagonal, float)) @ r.T
    if inertia is not None:
        inertia = inertia * kpu * mpu * mpu
    rot, shift = to_part[:3, :3], to_part[:3, 3]
    if com is not None:
        com = rot @ com + shift
    if inertia is not None:
        inertia = rot @ inertia @ rot.T
    if com is None or inertia is None:
        hull_com, hull_inertia = _hull_mass_properties(meshes, mass)
        warn(f"{where}: {'centre of mass' if com is None else 'inertia'}"
             f"{' and inertia' if com is None and inertia is None else ''} not authored; "
             "computed from the convex hull of the part's meshes at uniform density")
        com = hull_com if com is None else com
        inertia = hull_inertia if inertia is None else inertia
    return Inertial(mass, com, inertia)


def _at_authored_com(inertial: Inertial | None, api, to_part: np.ndarray, mpu: float,
                     scale: np.ndarray | None) -> Inertial | None:
    """A mass computed from the colliders with the body's authored centre of mass kept, as
    OpenUSD's ``ComputeMassProperties`` keeps it (each of mass, centre of mass and inertia
    stands as authored, the rest computed; the inertia then about that centre, by the
    parallel axis theorem), and Newton's importer: urdf-usd-converter states mass 0 and
    centre (0, 0, 0) for a link whose mass it leaves to the simulator."""
    com = api.GetCenterOfMassAttr().Get()
    if inertial is None or com is None or not np.all(np.isfinite(com)):
        return inertial
    com = np.asarray(com, float) * mpu * (scale if scale is not None else 1.0)
    com = to_part[:3, :3] @ com + to_part[:3, 3]
    d = inertial.com - com  # (the mass's warning says it is computed; nothing repaired)
    return Inertial(inertial.mass, com, inertial.inertia + inertial.mass * (
        float(d @ d) * np.eye(3) - np.outer(d, d)))


def principal_axes(api) -> np.ndarray:
    """The rotation a PhysicsMassAPI's ``principalAxes`` states: the identity where it is
    left at its fallback, the zero quaternion (only the diagonal authored), or is no
    rotation, as Newton's importer takes it (the quaternion normalised otherwise)."""
    axes = api.GetPrincipalAxesAttr().Get()
    q = np.array([axes.GetReal(), *axes.GetImaginary()], float) if axes is not None else None
    if q is None or not np.all(np.isfinite(q)) or np.linalg.norm(q) < 1e-6:
        return np.eye(3)
    return tf.quat_to_matrix(q / np.linalg.norm(q))


def collider_mass(shape, mpu: float, kpu: float) -> tuple[float, float]:
    """A collider prim's own PhysicsMassAPI mass (kg) and density (kg/m^3), else the density
    of the physics material bound to it (PhysicsMaterialAPI, UsdShade's "physics" purpose),
    as UsdPhysics' mass computation (and Newton's) takes it; 0 where not authored
    (:func:`read_inertial`)."""
    from pxr import UsdPhysics, UsdShade

    mass = density = 0.0
    if shape.HasAPI(UsdPhysics.MassAPI):
        api = UsdPhysics.MassAPI(shape)
        mass = max(float(api.GetMassAttr().Get() or 0.0), 0.0)
        density = max(float(api.GetDensityAttr().Get() or 0.0), 0.0)
    if mass <= 0.0 and density <= 0.0:
        material, _ = UsdShade.MaterialBindingAPI(shape).ComputeBoundMaterial(
            "physics")  # (the purpose UsdPhysics binds its materials for)
        if material and material.GetPrim().HasAPI(UsdPhysics.MaterialAPI):
            density = max(float(UsdPhysics.MaterialAPI(material.GetPrim()).GetDensityAttr()
                                .Get() or 0.0), 0.0)
    return mass * kpu, density * kpu / mpu**3


def _from_colliders(prim, colliders: list[Mesh], mpu: float, kpu: float, where: str,
                    own: list[tuple[float, float]] | None = None) -> Inertial | None:
    """A rigid body's mass properties as a simulator computes them where no mass is
    authored on it: its colliders', each at its own mass or density where it has one
    (``own``), else the body's density, else the default; None for a prim that is no rigid
    body (our frames: massless by design) or where no colliders are given (none, or a body
    that cannot move: its mass moves nothing)."""
    from pxr import UsdPhysics

    from ...inertia import combine_inertials, inertial_from_meshes

    if not prim.HasAPI(UsdPhysics.RigidBodyAPI) or not colliders:
        return None
    authored = float(UsdPhysics.MassAPI(prim).GetDensityAttr().Get() or 0.0) \
        if prim.HasAPI(UsdPhysics.MassAPI) else 0.0
    density = authored * kpu / mpu**3 if authored > 0.0 else SIMULATOR_DENSITY
    own = own or [(0.0, 0.0)] * len(colliders)
    weighed = sum(1 for mass, dens in own if mass > 0.0 or dens > 0.0)
    warn(f"{where}: mass not authored: computed from its {len(colliders)} collider(s)"
         + (f", {weighed} at their own mass or density (PhysicsMassAPI, or their physics "
            "material's) and the rest"
            if weighed else "")
         + f" at {density:g} kg/m^3 ({'authored' if authored > 0.0 else 'the simulators default'}"
         f"), {SIMULATORS_RULE}")
    if not weighed:
        return inertial_from_meshes(colliders, density)
    pieces = []
    for mesh, (mass, dens) in zip(colliders, own, strict=True):
        piece = inertial_from_meshes([mesh], dens if dens > 0.0 else density)
        if mass > 0.0:  # its mass as authored, distributed as its shape is
            piece = Inertial(mass, piece.com, piece.inertia * (mass / piece.mass))
        pieces.append((piece, np.eye(4)))
    return combine_inertials(pieces)


def _hull_mass_properties(meshes: list[Mesh], mass: float) -> tuple[np.ndarray, np.ndarray]:
    import trimesh

    if meshes:
        points = np.concatenate([m.vertices for m in meshes])
        try:
            hull = trimesh.convex.convex_hull(points)
            if hull.volume > 1e-12:
                hull.density = mass / hull.volume
                return np.asarray(hull.center_mass), np.asarray(hull.moment_inertia)
        except Exception:  # degenerate (flat) point sets: qhull refuses them
            pass
        centre = points.mean(axis=0)
    else:
        centre = np.zeros(3)
    return centre, np.eye(3) * mass * 1e-4  # a 1 cm radius of gyration
