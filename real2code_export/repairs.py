"""Repairs of the mass properties real description files carry, for readers to apply.

Robot files are written by hand and by CAD exporters: an inertia tensor off positive
definiteness by rounding (-2e-22), an all-zero tensor on a sensor frame, principal moments
that miss the triangle inequality, links without mass that carry a joint. Pinocchio loads
them all and MuJoCo loads most with its compiler's ``balanceinertia`` / ``boundmass`` /
``boundinertia``; the model (``model.validate``) wants a tensor a simulator can integrate. So
each reader repairs what those tools accept, says what it changed, and refuses the rest.

Plain functions: each returns the repaired value and a sentence describing the change (None
when nothing changed); the reader warns with the file and element.
"""

from __future__ import annotations

import numpy as np

from .model import ArticulatedObject, Inertial, JointType, Mimic, rigid_group_mass

# Principal moments below this fraction of the largest one are raised to it: far below any
# physical body's anisotropy, enough to keep the tensor positive definite in float64.
RELATIVE_MOMENT_FLOOR = 1e-6
TRIANGLE_MARGIN = 1e-6
# A tensor with products of inertia has its principal moments computed, by numpy here and by
# MuJoCo's own eigen solver there, to about 1e-16 of the largest: one this close to A + B = C
# (a CAD exporter's thin plate, 6e-16 short) may pass here and be refused there ("inertia
# must satisfy A + B >= C"), so it is balanced too. A diagonal tensor's moments are exact.
EIGEN_ROUNDING = 1e-12
# A point mass (an all-zero tensor) gets the inertia of a solid sphere this wide.
POINT_MASS_RADIUS = 1e-3  # m
# A movable part without mass gets this mass and the inertia of a POINT_MASS_RADIUS sphere
# (MuJoCo's ``boundmass``/``boundinertia`` do the same with the user's bounds).
NEGLIGIBLE_MASS = 1e-6  # kg


# No principal moment below this (kg m^2): MuJoCo refuses moments under its mjMINVAL (1e-15)
# once rotated and written as text; a 1e-9 kg "virtual" link would get 4e-16.
MIN_MOMENT = 1e-12
# A raised moment is at least this (kg m^2): MuJoCo's diagonalisation of a rotated
# fullinertia is exact to about mjMINVAL (1e-15) absolute, so a 6e-15 moment (1e-6 of a
# 4 g finger's 6e-9) can come back not positive; 100 mjMINVAL comes back positive.
ROTATED_MIN_MOMENT = 1e-13


def _sphere(mass: float) -> np.ndarray:
    return np.eye(3) * max(0.4 * mass * POINT_MASS_RADIUS**2, MIN_MOMENT)


def balanced_inertia(inertial: Inertial) -> tuple[Inertial, str | None]:
    """``inertial`` with a tensor a simulator accepts: symmetric, principal moments positive
    and satisfying the triangle inequality. Moments are only ever raised (never lowered), in
    the tensor's own principal axes: a negative or zero moment to the floor, the two smaller
    ones together just enough for A + B >= C. An all-zero tensor is a point mass and gets a
    1 mm sphere's inertia. Raises ValueError when no moment is positive but some is clearly
    negative (a tensor with its sign wrong, not rounding)."""
    tensor = 0.5 * (inertial.inertia + inertial.inertia.T)
    moments, axes = np.linalg.eigh(tensor)
    largest = float(moments[-1])
    scale = max(float(np.abs(moments).max()), 1e-300)
    # A smallest moment of zero up to rounding (1e-17 beside 0.2: a rod's tensor rotated and
    # written to 4 digits) is below what MuJoCo accepts (mjMINVAL, absolute) as well.
    # Nor may any moment be under ROTATED_MIN_MOMENT: MuJoCo refuses a fullinertia it finds
    # under mjMINVAL (a 1e-7 kg "virtual" link's 3e-22).
    floor = min(MIN_MOMENT, max(RELATIVE_MOMENT_FLOOR * largest, ROTATED_MIN_MOMENT))
    diagonal = not np.any(tensor - np.diag(np.diag(tensor)))
    slack = 0.0 if diagonal else EIGEN_ROUNDING * scale
    ok = moments[0] > 0 and moments[0] >= floor and moments[0] + moments[1] >= moments[2] + slack
    if ok:
        return inertial, None
    if scale <= 1e-12 * inertial.mass:  # zero, or zero up to rounding: a point mass
        repaired = _sphere(inertial.mass)
        return (Inertial(inertial.mass, inertial.com, repaired),
                f"inertia tensor is zero (principal moments {_fmt(moments)}; "
                f"{inertial.mass:g} kg at a point): given the inertia of a solid sphere "
                f"{2 * POINT_MASS_RADIUS * 1e3:g} mm wide")
    if largest <= 0:
        raise ValueError(f"inertia tensor has no positive principal moment "
                         f"({_fmt(moments)}): not a rounding error")
    new = np.maximum(moments, max(RELATIVE_MOMENT_FLOOR * largest, ROTATED_MIN_MOMENT))
    # Raise the two smaller moments evenly until A + B = C, with a margin so that the
    # tensor still passes once rotated and written as text (MuJoCo checks it strictly).
    deficit = new[2] * (1 + TRIANGLE_MARGIN) - new[0] - new[1]
    if deficit > 0:
        new[0] += deficit / 2
        new[1] += deficit / 2
    repaired = axes @ np.diag(new) @ axes.T
    repaired = 0.5 * (repaired + repaired.T)
    change = float(np.abs(new - moments).max() / largest)
    why = ("is not positive definite" if moments[0] <= 0 else
           "has a principal moment of zero up to rounding" if moments[0] < floor else
           "violates the triangle inequality (A + B >= C)")
    return (Inertial(inertial.mass, inertial.com, repaired),
            f"inertia tensor {why}: principal moments {_fmt(moments)} raised to {_fmt(new)} "
            f"(largest change {change:.3g} of the largest moment)")


def _fmt(values) -> str:
    return "[" + ", ".join(f"{v:.6g}" for v in values) + "]"


def negligible_inertial() -> Inertial:
    """What :func:`massless_moving_parts` gives a moving part without mass."""
    return Inertial(NEGLIGIBLE_MASS, np.zeros(3), _sphere(NEGLIGIBLE_MASS))


def massless_moving_parts(obj: ArticulatedObject) -> list[tuple[str, str]]:
    """Give every movable joint's child something to move: where the child and the parts
    fixed to it have no mass at all, the child gets a negligible mass (NEGLIGIBLE_MASS, a
    1 mm sphere's inertia at its frame origin). Changes ``obj`` in place; returns (joint name,
    message) for each part changed."""
    changed, tree = [], obj.tree()
    for joint in obj.joints:
        if joint.type is JointType.FIXED or rigid_group_mass(tree, joint.child) > 0:
            continue
        part = tree.parts[joint.child]
        part.inertial = negligible_inertial()
        changed.append((joint.name, f"moves part {joint.child!r}, which has no mass (nor any "
                        f"part fixed to it): given {NEGLIGIBLE_MASS:g} kg (a "
                        f"{2 * POINT_MASS_RADIUS * 1e3:g} mm sphere) as MuJoCo's boundmass "
                        "would"))
    return changed


def floating_joints_from_the_root(obj: ArticulatedObject) -> list[tuple[str, str]]:
    """Hang from the root part every floating joint whose parent the root holds by fixed
    joints (a URDF's floating body below a link welded to the base: Pinocchio loads it,
    MuJoCo allows free joints on top-level bodies only, urdf-usd-converter makes the body a
    free rigid body): the same pose, the joint origin composed with the fixed ones above
    it; a floating joint constrains nothing, so the motion is the same. One below a moving
    link is left to the model's validation (its coordinates would change). Changes ``obj``
    in place; returns (joint name, message) for each joint moved."""
    tree = obj.tree()
    changed = []
    for joint in obj.joints:
        if joint.type is not JointType.FLOATING or joint.parent not in tree.parent:
            continue
        origin, part, path = joint.origin, joint.parent, []
        while part in tree.parent and tree.parent[part].type is JointType.FIXED:
            above = tree.parent[part]
            origin, part = above.origin @ origin, above.parent
            path.append(above.name)
        if part in tree.parent:  # a joint above moves
            continue
        changed.append((joint.name, f"a floating joint below {joint.parent!r}, which the root "
                        f"part {part!r} holds by fixed joints ({', '.join(map(repr, path))}): "
                        f"hung from {part!r} at the same pose (a floating joint constrains "
                        "nothing; MuJoCo allows free joints on top-level bodies only)"))
        joint.parent, joint.origin = part, origin
    return changed


def composed_mimic_chains(obj: ArticulatedObject) -> list[tuple[str, str]]:
    """Couple a follower whose leader follows a third joint (MJCF joint equalities chained,
    each of which MuJoCo applies; URDF mimics chained) to the chain's first leader directly:
    q = m1 (m2 q_lead + o2) + o1 is one mimic with multiplier m1 m2 and offset m1 o2 + o1, the
    same coupling, which every format's mimic holds (URDF's and USD's name a leader that
    follows nothing). A cycle, or a chain to a joint that does not exist, is left to
    :func:`unusable_mimics` or the model's validation. Changes ``obj`` in place; returns
    (joint name, message) for each mimic changed."""
    joints = {j.name: j for j in obj.joints}
    changed = []
    for joint in obj.joints:
        mimic = joint.mimic
        if mimic is None:
            continue
        multiplier, offset, path = mimic.multiplier, mimic.offset, [mimic.joint]
        leader = joints.get(mimic.joint)
        while leader is not None and leader.mimic is not None and leader.name not in path[:-1] \
                and leader is not joint:
            step = leader.mimic
            multiplier, offset = multiplier * step.multiplier, multiplier * step.offset + offset
            path.append(step.joint)
            leader = joints.get(step.joint)
        if len(path) == 1 or leader is None or leader.mimic is not None:
            continue  # no chain, or one that ends nowhere or turns round: not composed
        joint.mimic = Mimic(leader.name, multiplier, offset)
        changed.append((joint.name, f"mimics {' which mimics '.join(map(repr, path))}: "
                        f"coupled to {leader.name!r} directly (multiplier {multiplier:g}, "
                        f"offset {offset:g}), the same coupling"))
    return changed


def unusable_mimics(obj: ArticulatedObject) -> list[tuple[str, str]]:
    """Drop the mimics no simulator can apply: a leader that does not exist, is not a
    one-value joint or mimics another itself (a cycle, once :func:`composed_mimic_chains`
    has composed the chains), or a follower that is not one (urdfdom loads
    such files; the followers then move on their own). Changes ``obj`` in place; returns
    (joint name, message) for each mimic dropped."""
    joints = {j.name: j for j in obj.joints}
    dropped = []
    for joint in obj.joints:
        m = joint.mimic
        if m is None:
            continue
        leader = joints.get(m.joint)
        why = ("it does not exist" if leader is None else "it is the joint itself"
               if leader is joint else f"it is {leader.type.value}"
               if not leader.type.movable else "it mimics another joint itself"
               if leader.mimic is not None else None)
        if why is None and not joint.type.movable:
            why = f"the follower is {joint.type.value}"
        if why is not None:
            joint.mimic = None
            dropped.append((joint.name, f"<mimic> of joint {m.joint!r} dropped ({why}): the "
                            "joint moves on its own"))
    return dropped

