"""A source file's dynamics as its own tools compile it, against an export's: what "dynamics
carried" means for a user's file, beyond our reader and writer agreeing with each other.

- MJCF source, MJCF export, both compiled by MuJoCo: per named body its mass, principal
  moments and centre of mass at q = 0; per named joint damping, frictionloss, armature,
  stiffness, range and ref (qpos0, where the joint starts) (:func:`mjcf_differences`).
- URDF source, URDF export, both built by Pinocchio: per joint the inertia of everything
  rigidly attached to it (Pinocchio merges fixed links into their joint, as we may merge or
  split them), in the world at the neutral configuration; damping, friction, armature,
  position, velocity and effort limits (:func:`urdf_differences`).
- URDF source in MuJoCo's URDF import, MJCF export: per welded group of bodies (MuJoCo's
  ``body_weldid``: a moving body with the bodies fixed to it) its mass, principal moments
  and centre of mass; per joint as above (:func:`urdf_mujoco_differences`).
- MJCF source, URDF export in MuJoCo's URDF import: the same per welded group; per joint
  what a URDF holds as MuJoCo reads it (:func:`mjcf_urdf_differences`).
- MJCF source (or a URDF source MuJoCo loads as it is), USD or glTF export as its schema
  states it (``probes.schema_dynamics``): the same per welded group; per joint what the
  schema holds (:func:`schema_differences`).

:func:`against_source` picks, for each export, the comparison its tool makes (``check
--reference``). Names are compared as our importers make them (``model.sanitize_name``). Each function returns
a :class:`Difference` per quantity beyond ``tol`` (absolute and relative), naming the source's
elements it concerns, so that a caller can tell a reader's warned repair (a warning naming one
of them and saying what it changed of that kind: :func:`explaining`) from a loss; an empty
list means equal.
"""

from __future__ import annotations

import dataclasses
import re
import warnings
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .. import transforms as tf
from ..errors import Real2CodeWarning
from ..formats.usd.body import SIMULATORS_RULE
from ..inertia import combine_inertials
from ..model import UNBOUNDED_LIMIT, Inertial, sanitize_name
from ..mujoco_files import spec_from_file
from ._stdio import captured_c_output

if TYPE_CHECKING:
    from .schema_dynamics import SchemaDynamics

# What a warning that explains a joint missing from the export says: any change of the joint.
JOINT_WORDS = ("limit", "range", "joint", "damping", "friction", "armature")
# What a warning that explains a difference in one mass property of a rigid group says, as
# a word of its own (the mass changes all three; a tensor repaired, the moments; an
# inertial dropped or computed, the moments and the centre of mass).
MASS_WORDS = {"mass": ("mass",), "principal moments": ("mass", "inertia", "inertial", "moments"),
              "centre of mass": ("mass", "inertial")}


@dataclass(frozen=True)
class Difference:
    names: tuple[str, ...]  # the source's links, bodies or joint it concerns
    message: str
    words: tuple[str, ...] = JOINT_WORDS  # one of which a warning explaining it says
    # the words count only as whole words of the warning's own prose, not inside the file's
    # elements it quotes: "<mass value='0'>: treated as massless" changed no mass
    prose: bool = False
    # what a warning says that makes it no explanation of this difference: the reader
    # following the very rule the source's tool follows changed nothing against it
    not_by: tuple[str, ...] = ()

    def __str__(self) -> str:
        return self.message


_QUOTED_ELEMENT = re.compile(r"<[^<>]*>")


def explaining(difference: Difference, warned: list[str]) -> list[str]:
    """The warnings that explain ``difference``: a reader's repair names the element it
    changed (``'NAME'``, as the source spells it or as our importers name it: a link
    ``fl.hip`` is part ``fl_hip``) and says what of it changed, the quantity that differs
    (its mass, its tensor; its damping, its limit: :attr:`Difference.words`), not another."""
    names = {f"'{m}'" for n in difference.names for m in (n, sanitize_name(n))} | {
        f"<{n}>" for n in difference.names if n.startswith("/")}  # (a USD prim's path)
    return [w for w in warned if any(n in w for n in names) and _says(w, difference)
            and not any(phrase in w for phrase in difference.not_by)]


def _says(warning: str, difference: Difference) -> bool:
    if not difference.prose:
        return any(word in warning for word in difference.words)
    prose = _QUOTED_ELEMENT.sub(" ", warning)
    return any(re.search(rf"\b{re.escape(word)}s?\b", prose) for word in difference.words)


def unexplained(differences: list[Difference], warned: list[str]) -> list[Difference]:
    """The differences that no warning explains (:func:`explaining`)."""
    return [d for d in differences if not explaining(d, warned)]


def _close(x, y, tol: float) -> bool:
    return bool(np.allclose(np.asarray(x, float), np.asarray(y, float), atol=tol, rtol=tol))


# -- MuJoCo ---------------------------------------------------------------------------------
def _compiled(spec):
    """``spec`` compiled, at rest (:func:`_at_rest`)."""
    with captured_c_output():
        return _at_rest(spec.compile())


def _at_rest(m):
    """The model and its data at q = 0 for hinges and slides (a joint's ref makes qpos0
    differ, not its pose at a value), balls and free joints at qpos0 (their rest)."""
    import mujoco

    d = mujoco.MjData(m)
    d.qpos[:] = m.qpos0
    for j in range(m.njnt):
        if int(m.jnt_type[j]) in (int(mujoco.mjtJoint.mjJNT_HINGE),
                                  int(mujoco.mjtJoint.mjJNT_SLIDE)):
            d.qpos[m.jnt_qposadr[j]] = 0.0
    mujoco.mj_kinematics(m, d)
    return m, d


def _mjcf(path: str | Path, compiled: Mapping[Path, object] | None):
    """An MJCF file as MuJoCo compiles it, every body kept, at rest: the model a kinematic
    probe compiled already where ``compiled`` holds one (path -> MjModel; its contact
    exclusions and visual geoms dropped, which move and weigh nothing), else compiled here."""
    model = (compiled or {}).get(Path(path))
    if model is not None:
        return _at_rest(model)
    spec = spec_from_file(path)
    spec.compiler.fusestatic = False
    return _compiled(spec)


# What a URDF holds of a joint as MuJoCo imports it (<dynamics damping friction>, <limit>);
# armature, stiffness and the spring's reference are in our namespace, which MuJoCo skips.
URDF_HOLDS = ("damping", "frictionloss", "limited", "range")


def _mujoco_joint_differences(src, exp, tol: float, held: tuple[str, ...] | None = None,
                              balls: bool = True) -> list[Difference]:
    """Per named joint of ``src``: damping, frictionloss, armature, stiffness, limited,
    (hinge, slide) range and ref, against the joint of that name in ``exp``; ``held``: only
    those quantities, ``balls`` False: not its ball joints (what the export's format holds
    as its tool reads it)."""
    import mujoco

    out = []
    ball = int(mujoco.mjtJoint.mjJNT_BALL)
    for j in range(src.njnt):
        name = src.joint(j).name
        if not name or (not balls and int(src.jnt_type[j]) == ball):
            continue
        e = mujoco.mj_name2id(exp, mujoco.mjtObj.mjOBJ_JOINT, sanitize_name(name))
        if e < 0:
            out.append(Difference((name,), f"joint {name!r}: not in the export"))
            continue
        ours, theirs = _joint_quantities(src, j), _joint_quantities(exp, e)
        theirs["ref"] = exp.qpos0[exp.jnt_qposadr[e]]
        theirs.setdefault("range", exp.jnt_range[e])
        out += [Difference((name,), f"joint {name!r}: {_LABELS.get(q, q)} {a} != {theirs[q]}",
                           QUANTITY_WORDS[q])
                for q, a in ours.items()
                if (held is None or q in held) and not _close(a, theirs[q], tol)]
    return out


_LABELS = {"ref": "ref (qpos0)"}


def _limited(m, j: int) -> bool:
    """Whether joint ``j`` has a range: one at SDF's "no limit" (+-1e16, which a URDF, whose
    slides must have one, is given for a slide without) is none."""
    return bool(m.jnt_limited[j]) and not np.all(
        np.abs(m.jnt_range[j]) >= UNBOUNDED_LIMIT * (1.0 - 1e-6))


def mjcf_differences(source: str | Path, export: str | Path, tol: float = 1e-6,
                     compiled: Mapping[Path, object] | None = None) -> list[Difference]:
    """An MJCF SOURCE against its MJCF EXPORT, both compiled by MuJoCo (``compiled``:
    :func:`_mjcf`), body by body."""
    import mujoco

    (src, ds), (exp, de) = _mjcf(source, compiled), _mjcf(export, compiled)
    out = []
    for b in range(1, src.nbody):
        name = src.body(b).name
        e = mujoco.mj_name2id(exp, mujoco.mjtObj.mjOBJ_BODY, sanitize_name(name)) if name else -1
        if e < 0:
            continue  # a body the export names otherwise is the kinematic check's business
        out += _mass_differences(f"body {name!r}", (name,),
                                 (src.body_mass[b], src.body_inertia[b], ds.xipos[b]),
                                 (exp.body_mass[e], exp.body_inertia[e], de.xipos[e]), tol)
    return out + _mujoco_joint_differences(src, exp, tol)


def _mass_differences(element: str, names: tuple[str, ...], a, b,
                      tol: float) -> list[Difference]:
    """(mass, principal moments, centre of mass in the world) of one rigid group each. Of
    two massless groups only the mass is compared: where a tool puts the centre of mass of
    nothing (its body's origin, which a body split at its joints moves) means nothing."""
    pairs = (("mass", a[0], b[0]), ("principal moments", np.sort(a[1]), np.sort(b[1])),
             ("centre of mass", a[2], b[2]))
    if _close(a[0], 0.0, tol) and _close(b[0], 0.0, tol):
        pairs = pairs[:1]
    return [Difference(names, f"{element}: {what} {x} != {y}", MASS_WORDS[what], prose=True)
            for what, x, y in pairs if not _close(x, y, tol)]


def _welded_groups(m, d, welds: dict[int, list[int]]
                   ) -> dict[int, tuple[float, np.ndarray, np.ndarray]]:
    """Weld body id (a body with a joint, or the world) -> (mass, principal moments, centre
    of mass in the world) of it and every body fixed to it (``welds``: :func:`_welds`)."""
    out = {}
    for weld, bodies in welds.items():
        mass = float(sum(m.body_mass[b] for b in bodies))
        if mass <= 0.0:
            out[weld] = (0.0, np.zeros(3), np.zeros(3))
            continue
        group = combine_inertials([  # each body's principal frame placed in the world
            (Inertial(m.body_mass[b], np.zeros(3), np.diag(m.body_inertia[b])),
             tf.make(d.ximat[b].reshape(3, 3), d.xipos[b])) for b in bodies])
        out[weld] = (mass, np.linalg.eigvalsh(group.inertia), group.com)
    return out


def _body_name(m, b: int) -> str:
    """A body's name as our readers make it (an unnamed MJCF body is ``body_<id>``)."""
    return m.body(b).name or f"body_{b}"


def _welds(m, as_urdf: bool = False) -> dict[int, list[int]]:
    """Weld body id -> the bodies welded to it (MuJoCo's ``body_weldid``), a mocap body
    (moved by the user, on no joint: fixed in every export) welded to its parent too;
    ``as_urdf``: as a URDF holds them, a body whose joints are all ball joints too."""
    import mujoco

    weld = [int(w) for w in m.body_weldid]
    ball = int(mujoco.mjtJoint.mjJNT_BALL)
    for b in range(1, m.nbody):  # (parents come before their children)
        first = int(m.body_jntadr[b])  # (a body's joints are consecutive)
        kinds = {int(t) for t in m.jnt_type[first:first + int(m.body_jntnum[b])]}
        if (as_urdf and kinds == {ball}) or m.body_mocapid[b] >= 0 or \
                (not kinds and weld[b] != b):
            weld[b] = weld[int(m.body_parentid[b])]
    groups: dict[int, list[int]] = {}
    for b in range(1, m.nbody):
        groups.setdefault(weld[b], []).append(b)
    return groups


def urdf_mujoco_differences(source: str | Path, export: str | Path, tol: float = 1e-6,
                            compiled: Mapping[Path, object] | None = None, in_mujoco=None
                            ) -> list[Difference] | None:
    """A URDF SOURCE as MuJoCo imports it (kinematics and masses, every link kept a body, no
    repair of MuJoCo's turned on) against the MJCF EXPORT, per welded group named by its
    moving body, and per joint; None when MuJoCo refuses the source as it is. ``in_mujoco``:
    :func:`_source_in_mujoco` of the source, where a caller has it already."""
    found = in_mujoco or [_source_in_mujoco(Path(source), True, compiled)]
    if found[0] is None:
        return None  # (a tensor off the triangle inequality, a massless moving link)
    src, ds = found[0]
    exp, de = _mjcf(export, compiled)
    return _welded_differences(src, ds, exp, de, tol) + _mujoco_joint_differences(src, exp, tol)


def mjcf_urdf_differences(source: str | Path, export: str | Path, tol: float = 1e-6,
                          compiled: Mapping[Path, object] | None = None) -> list[Difference]:
    """An MJCF SOURCE against its URDF EXPORT as MuJoCo imports it, per welded group named by
    its moving body (a body of several joints is a chain in a URDF: its last link carries the
    mass; a ball joint is fixed at its rest, a mocap body fixed), and per joint what a URDF
    holds (:data:`URDF_HOLDS`)."""
    src, ds = _mjcf(source, compiled)
    exp, de = _compiled(_urdf_spec(Path(export)))
    # a URDF has no ball joint (the writer fixes one at its rest, warned) nor mocap body
    return (_welded_differences(src, ds, exp, de, tol, as_urdf=True)
            + _mujoco_joint_differences(src, exp, tol, held=URDF_HOLDS, balls=False))


def _urdf_spec(path: Path):
    """A URDF as MuJoCo imports it: kinematics and masses, every link kept a body, none of
    MuJoCo's repairs turned on."""
    import mujoco

    from .mujoco import urdf_kinematics

    spec = mujoco.MjSpec.from_string(urdf_kinematics(path))
    spec.compiler.fusestatic = False
    return spec


def _welded_differences(src, ds, exp, de, tol: float,
                        as_urdf: bool = False) -> list[Difference]:
    """Per welded group of ``src`` that moves, named by its moving body, against the group
    that holds the body of that name in ``exp``; ``as_urdf``: ``src``'s welds as a URDF holds
    them (:func:`_welds`)."""
    import mujoco

    members = _welds(src, as_urdf)
    a, b = _welded_groups(src, ds, members), _welded_groups(exp, de, _welds(exp))
    out = []
    for weld, group in a.items():
        if weld == 0:
            continue  # the world's own share: which links MuJoCo counts in it is its choice
        name = _body_name(src, weld)
        names = tuple(_body_name(src, k) for k in members[weld])
        e = mujoco.mj_name2id(exp, mujoco.mjtObj.mjOBJ_BODY, sanitize_name(name))
        if e < 0 or int(exp.body_weldid[e]) == 0:
            out.append(Difference(names, f"body {name!r}: no moving body of that name in "
                                         "the export"))
            continue
        # (the group it is in: a body of a hinge and a ball, split at its joints, hangs on
        # its hinge's intermediate part, a URDF fixing the ball)
        out += _mass_differences(f"body {name!r} and the bodies fixed to it", names, group,
                                 b[int(exp.body_weldid[e])], tol)
    return out


def schema_differences(src, ds, view, tol: float) -> list[Difference]:
    """A source compiled by MuJoCo (``src``, ``ds`` at rest) against what a USD or glTF
    export states in its schema (``view``: ``probes.schema_dynamics``), per welded group
    named by its moving body (a ball joint and a free body move in both), and per joint
    each value the schema holds (a free joint has no joint there)."""
    import mujoco

    members = _welds(src)
    out, inertias = [], view.group_inertias()
    for weld, group in _welded_groups(src, ds, members).items():
        if weld == 0:
            continue
        name = _body_name(src, weld)
        names = tuple(_body_name(src, k) for k in members[weld])
        key = view.group.get(sanitize_name(name))
        if key is None or key == "":
            out.append(Difference(names, f"body {name!r}: no moving body of that name in "
                                         "the export"))
            continue
        theirs = inertias[key]
        if isinstance(theirs, str):
            out.append(Difference(names, f"body {name!r}: {theirs}",  # (left unstated)
                                  ("mass", "inertia"), prose=True))
            continue
        out += _mass_differences(f"body {name!r} and the bodies fixed to it", names, group,
                                 theirs, tol)
    free = int(mujoco.mjtJoint.mjJNT_FREE)
    for j in range(src.njnt):
        name = src.joint(j).name
        if not name or int(src.jnt_type[j]) == free:
            continue
        stated = view.joints.get(sanitize_name(name))
        if stated is None:
            out.append(Difference((name,), f"joint {name!r}: not in the export"))
            continue
        ours = _joint_quantities(src, j)
        out += [Difference((name,), f"joint {name!r}: {what} {ours[q]} != {value}",
                           QUANTITY_WORDS[q])
                for what, q, value in stated if q in ours and not _close(ours[q], value, tol)]
    return out


def view_differences(src, exp, tol: float,
                     left_out: list[str] | None = None) -> list[Difference]:
    """A source's dynamics as its tool holds them against an export's, both as
    ``schema_dynamics.SchemaDynamics`` (a USD source in Newton: ``newton_dynamics``), per
    group of welded bodies of the source that moves, looked up in the export by a body of
    it, and per joint each value the export holds. A group the source's tool weighs
    otherwise than the file states (``src.unstated``) is not compared: said in
    ``left_out``."""
    left_out = [] if left_out is None else left_out
    left_out += src.left_out
    from .schema_dynamics import WORLD

    members: dict[str, list[str]] = {}
    for body, key in src.group.items():
        members.setdefault(key, []).append(body)
    ours, theirs = src.group_inertias(), exp.group_inertias()
    out = []
    for key, names in members.items():
        if key == WORLD:
            continue  # the world's own share
        found = next((exp.group[n] for n in names if n in exp.group), None)
        if found is None or found == WORLD:
            out.append(Difference(tuple(names), f"body {key!r}: no moving body of that name "
                                                "in the export"))
            continue
        if isinstance(ours[key], str):  # (the source's tool reads it otherwise: left out)
            left_out.append(ours[key])
            continue
        group = theirs[found]
        if isinstance(group, str):
            out.append(Difference(tuple(names), f"body {key!r}: {group}", ("mass", "inertia"),
                                  prose=True))
            continue
        # (named by the source's prims' paths too: what our USD reader's warnings name)
        found_differences = _mass_differences(
            f"body {key!r} and the bodies fixed to it",
            (*names, *(src.paths[n] for n in names if n in src.paths)), ours[key], group, tol)
        stand_in = [n for n in names if n in src.stand_in_inertia]
        if stand_in:  # (its mass and centre of mass compared, not its moments)
            found_differences = [d for d in found_differences
                                 if "principal moments" not in d.message]
            left_out.append(f"body {key!r}: the principal moments, for Newton's stand-in "
                            f"inertia of {', '.join(repr(n) for n in stand_in)} (a sphere of "
                            "its mass at its default density, where its mass computation "
                            "gives no tensor)")
        out += found_differences
    for name, items in src.joints.items():
        stated = exp.joints.get(name)
        if stated is None:
            out.append(Difference((name,), f"joint {name!r}: not in the export"))
            continue
        held = {q: v for _, q, v in items}
        out += [Difference((name,), f"joint {name!r}: {what} {held[q]} != {value}",
                           QUANTITY_WORDS[q])
                for what, q, value in stated if q in held and not _close(held[q], value, tol)]
    return out


# What a warning explaining a difference in one quantity of a joint says of it (a warning
# about the joint's mass or its type explains no change of its damping or range).
QUANTITY_WORDS = {"damping": ("damping",), "frictionloss": ("friction",),
                  "armature": ("armature",), "stiffness": ("stiffness", "spring"),
                  "limited": ("limit", "range"), "range": ("limit", "range"),
                  "ref": ("limit", "range", "ref", "state")}


def _joint_quantities(m, j: int) -> dict[str, object]:
    """Joint ``j``'s damping, frictionloss, armature, stiffness, limited, range (a limited
    hinge or slide; a limited ball's [0, cone]) and ref (qpos0 of a hinge or slide, where inside its range: a start
    outside is the nearest limit in the model, warned by the reader)."""
    import mujoco

    d = m.jnt_dofadr[j]
    out: dict[str, object] = {"damping": m.dof_damping[d], "frictionloss": m.dof_frictionloss[d],
                              "armature": m.dof_armature[d], "stiffness": m.jnt_stiffness[j],
                              "limited": _limited(m, j)}
    if int(m.jnt_type[j]) == int(mujoco.mjtJoint.mjJNT_BALL) and out["limited"]:
        out["range"] = m.jnt_range[j]  # [0, the largest rotation]
    if int(m.jnt_type[j]) in (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)):
        if out["limited"]:
            out["range"] = m.jnt_range[j]
        ref = m.qpos0[m.jnt_qposadr[j]]
        lo, hi = m.jnt_range[j] if out["limited"] else (-np.inf, np.inf)
        if lo <= ref <= hi:
            out["ref"] = ref
    return out


# -- Pinocchio ------------------------------------------------------------------------------
def _pinocchio(path: Path):
    import pinocchio as pin

    from .pinocchio import build_model

    model = build_model(path)
    data = model.createData()
    pin.forwardKinematics(model, data, pin.neutral(model))
    return model, data


def urdf_differences(source: str | Path, export: str | Path,
                     tol: float = 1e-6) -> list[Difference]:
    """A URDF SOURCE against its URDF EXPORT, both built by Pinocchio, joint by joint (the
    universe's share included: links fixed to the world)."""
    import pinocchio as pin

    (src, ds), (exp, de) = _pinocchio(Path(source)), _pinocchio(Path(export))
    ids = {name: k for k, name in enumerate(exp.names)}
    links: dict[int, list[str]] = {}
    for frame in src.frames:
        if frame.type == pin.FrameType.BODY:
            links.setdefault(int(frame.parentJoint), []).append(frame.name)
    out = []
    for j in range(src.njoints):
        name = src.names[j]
        e = 0 if j == 0 else ids.get(sanitize_name(name), -1)
        if e < 0:
            out.append(Difference((name,), f"joint {name!r}: not in the export"))
            continue
        out += _mass_differences(f"the links of joint {name!r}", tuple(links.get(j, ())),
                                 _world_inertia(src, ds, j), _world_inertia(exp, de, e), tol)
        if j > 0:
            out += _pinocchio_joint_differences(src, exp, j, e, tol)
    return out


def _pinocchio_joint_differences(src, exp, j: int, e: int, tol: float) -> list[Difference]:
    name = src.names[j]
    js, je = src.joints[j], exp.joints[e]
    vs, ve = slice(js.idx_v, js.idx_v + js.nv), slice(je.idx_v, je.idx_v + je.nv)
    pairs = [(what, getattr(src, what)[vs], getattr(exp, what)[ve])
             for what in ("damping", "friction", "armature", "effortLimit", "velocityLimit")]
    if js.nq == js.nv == 1:  # revolute, prismatic: a range (a continuous joint: cos, sin)
        for what in ("lowerPositionLimit", "upperPositionLimit"):
            theirs = getattr(exp, what)[je.idx_q] if je.nq == 1 else f"none ({je.shortname()})"
            pairs.append((what, getattr(src, what)[js.idx_q], theirs))
    return [Difference((name,), f"joint {name!r}: {what} {x} != {y}", PINOCCHIO_WORDS[what])
            for what, x, y in pairs
            if isinstance(y, str) or np.shape(x) != np.shape(y) or not _close(x, y, tol)]


# The same for Pinocchio's joint quantities.
PINOCCHIO_WORDS = {"damping": ("damping",), "friction": ("friction",),
                   "armature": ("armature",), "effortLimit": ("effort",),
                   "velocityLimit": ("velocity",), "lowerPositionLimit": ("limit", "range"),
                   "upperPositionLimit": ("limit", "range")}


def _world_inertia(model, data, j: int) -> tuple[float, np.ndarray, np.ndarray]:
    """(mass, principal moments, centre of mass in the world) of joint ``j``'s links."""
    inertia = data.oMi[j].act(model.inertias[j])
    return float(inertia.mass), np.linalg.eigvalsh(inertia.inertia), np.array(inertia.lever)


# -- a source against its exports (``check --reference``) -------------------------------
@dataclass(frozen=True)
class Comparison:
    """One export's dynamics against the source's, in one tool."""

    export: Path
    tool: str  # the tool both were built in: "MuJoCo" or "Pinocchio"
    differences: list[Difference] | None  # None: the tool refuses the source as it is
    note: str = ""  # why it is not compared (with differences None)


def against_source(source: str | Path, exports: list[str | Path], tol: float = 1e-6,
                   compiled: Mapping[Path, object] | None = None,
                   opened: Mapping[Path, object] | None = None,
                   newton: dict | None = None) -> list[Comparison]:
    """The dynamics of each export that a tool of the source builds, against the source in
    that tool: an MJCF source's MJCF exports in MuJoCo (:func:`mjcf_differences`); a URDF
    source's URDF exports in Pinocchio (:func:`urdf_differences`) and MJCF exports in MuJoCo
    (:func:`urdf_mujoco_differences`); an MJCF source's URDF exports as MuJoCo imports them
    (:func:`mjcf_urdf_differences`); USD and glTF exports as their schemas state them
    against the source in MuJoCo (:func:`schema_differences`). ``compiled``: MJCF files'
    models that the kinematic probes compiled already (path -> MjModel), used instead of
    compiling the files again; ``opened``: USD and glTF files' probes opened already (path
    -> probe), whose stage and document are read instead of opening the files again.
    A USD source: ``newton``, Newton's model's dynamics (``probes.newton``'s answer), against
    every export as its tool or schema holds them (:func:`against_newton`)."""
    from ..errors import CheckError
    from ..formats import format_for_path

    source = Path(source)
    if newton is not None:
        return against_newton(source, newton, exports, tol, compiled, opened)
    is_urdf = format_for_path(source).name == "urdf"
    in_mujoco: list = []  # the source compiled by MuJoCo, once: [(model, data) or None]
    out = []
    for export in map(Path, exports):
        kind = format_for_path(export).name
        if kind == "mjcf":
            if is_urdf:
                if not in_mujoco:
                    in_mujoco.append(_source_in_mujoco(source, is_urdf, compiled))
                found = urdf_mujoco_differences(source, export, tol, compiled, in_mujoco)
                note = "" if found is not None else "MuJoCo refuses the source as it is"
            else:
                found, note = mjcf_differences(source, export, tol, compiled), ""
            out.append(Comparison(export, "MuJoCo", found, note))
        elif kind == "urdf" and not is_urdf:
            out.append(Comparison(export, "MuJoCo",
                                  mjcf_urdf_differences(source, export, tol, compiled)))
        elif kind == "urdf":
            try:
                out.append(Comparison(export, "Pinocchio", urdf_differences(source, export, tol)))
            except CheckError as e:  # Pinocchio refuses the source (or the export: the
                if str(source) not in str(e):  # kinematic check says so too)
                    raise
                out.append(Comparison(export, "Pinocchio", None,
                                      "Pinocchio refuses the source"))
        elif kind in SCHEMA_TOOLS:
            if not in_mujoco:
                in_mujoco.append(_source_in_mujoco(source, is_urdf, compiled))
            tool = SCHEMA_TOOLS[kind]
            if in_mujoco[0] is None:
                out.append(Comparison(export, tool, None, "MuJoCo refuses the source as it is"))
                continue
            view = _schema_view(kind, export, opened)
            if view is None:
                out.append(Comparison(export, tool, None, "a glTF without our node extras: "
                                      "its bodies are not posed here"))
                continue
            out.append(Comparison(export, tool, schema_differences(*in_mujoco[0], view, tol)))
    return out


# the tool named for a USD or glTF export's comparison: the source's in MuJoCo, the export's
# as its schema states it (``probes.schema_dynamics``)
SCHEMA_TOOLS = {"usd": "MuJoCo / UsdPhysics", "gltf": "MuJoCo / KHR_physics_rigid_bodies"}


def _source_in_mujoco(source: Path, is_urdf: bool, compiled):
    """(model, data) of the source compiled by MuJoCo at rest; None when MuJoCo refuses a
    URDF source as it is."""
    if not is_urdf:
        return _mjcf(source, compiled)
    try:
        return _compiled(_urdf_spec(source))
    except ValueError:
        return None


def _schema_view(kind: str, export: Path, opened: Mapping[Path, object] | None):
    from . import open_probes, schema_dynamics

    probe = (opened or {}).get(export)
    if probe is None:
        probe = open_probes(export)[0]
    if kind == "usd":
        return schema_dynamics.usd_dynamics(probe)
    if not hasattr(probe, "node_poses"):  # (``probes.gltf.ImportedGltfProbe``)
        return None
    return schema_dynamics.gltf_dynamics(probe)


# What our USD reader says where it weighs a body as Newton does (colliders at their
# densities): no repair, so no explanation of a difference with Newton's model
NEWTON_RULES = (SIMULATORS_RULE,)

# the tool named for an export's comparison with a USD source's model in Newton
NEWTON_TOOLS = {"mjcf": "Newton / MuJoCo", "urdf": "Newton / MuJoCo (URDF import)",
                "usd": "Newton / UsdPhysics", "gltf": "Newton / KHR_physics_rigid_bodies"}


def against_newton(source: Path, newton: dict, exports: list[str | Path], tol: float,
                   compiled: Mapping[Path, object] | None,
                   opened: Mapping[Path, object] | None) -> list[Comparison]:
    """A USD source's dynamics as Newton's model holds them (``newton``: the probe's
    answer) against each export's: an MJCF export compiled by MuJoCo, a URDF export as
    MuJoCo imports it (per welded group, per joint: :func:`view_differences`), a USD or
    glTF export as its schema states it (``probes.schema_dynamics``)."""
    from ..formats import format_for_path
    from . import schema_dynamics

    out, left_out = [], []
    for export in map(Path, exports):
        kind = format_for_path(export).name
        if kind == "mjcf":
            m, d = _mjcf(export, compiled)
            view = mujoco_dynamics(str(export), m, d, _welds(m))
        elif kind == "urdf":  # (what a URDF holds of a joint: URDF_HOLDS)
            m, d = _compiled(_urdf_spec(export))
            view = mujoco_dynamics(str(export), m, d, _welds(m))
            view.joints = {name: [i for i in items if i[1] in URDF_HOLDS]
                           for name, items in view.joints.items()}
        elif kind in SCHEMA_TOOLS:
            view = _schema_view(kind, export, opened)
            if view is None:
                out.append(Comparison(export, NEWTON_TOOLS[kind], None, "a glTF without our "
                                      "node extras: its bodies are not posed here"))
                continue
        else:
            continue
        left_out.clear()
        src = schema_dynamics.newton_dynamics(str(source), newton, as_urdf=kind == "urdf")
        out.append(Comparison(export, NEWTON_TOOLS[kind], [
            dataclasses.replace(d, not_by=NEWTON_RULES)
            for d in view_differences(src, view, tol, left_out)]))
    if left_out:
        warnings.warn(f"{source}: not compared with Newton's model: {'; '.join(left_out)}",
                      Real2CodeWarning, stacklevel=2)
    return out


def mujoco_dynamics(path: str, m, d, welds: dict[int, list[int]]) -> SchemaDynamics:
    """An MJCF file, or a URDF in MuJoCo's import, as MuJoCo compiles it (``m``, ``d`` at
    rest; ``welds``: ``probes.dynamics._welds``): per body its mass, inertia and centre of
    mass in the world, its group (named by its moving body), per named joint (a free joint
    none) damping, frictionloss, armature, stiffness, limited and range."""
    import mujoco

    from .schema_dynamics import WORLD, SchemaDynamics

    out = SchemaDynamics(str(path))
    for weld, bodies in welds.items():
        for b in bodies:
            turn = d.ximat[b].reshape(3, 3)
            out.bodies[_body_name(m, b)] = (float(m.body_mass[b]),
                                            turn @ np.diag(m.body_inertia[b]) @ turn.T,
                                            np.array(d.xipos[b], float))
            out.group[_body_name(m, b)] = _body_name(m, weld) if weld else WORLD
    free = int(mujoco.mjtJoint.mjJNT_FREE)
    for j in range(m.njnt):
        if m.joint(j).name and int(m.jnt_type[j]) != free:
            out.joints[m.joint(j).name] = [(q, q, v) for q, v in _joint_quantities(m, j).items()
                                           if q != "ref"]
    return out
