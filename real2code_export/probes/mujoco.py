"""MJCF and URDF loaded in MuJoCo (MjSpec), posed with ``mj_kinematics``.

Joints are addressed by name (``qposadr``), bodies and named sites (frames) by name; a free
or ball joint is not a part joint and is held at its reference pose. A body's reported pose is its frame moved to its
(last) joint's anchor, the model's "part frame = joint frame" (as the MJCF reader and the USD
probe have it); a joint at the body origin, as in every file we write, moves nothing.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..dynamics.overlap import drop_exclusions
from ..errors import CheckError, NameNotFoundError
from ..formats import format_for_path
from ..mujoco_files import spec_from_file
from . import JointInfo
from ._stdio import captured_c_output


class MujocoProbe:
    def __init__(self, path: Path, label: str, model, body_ids: list[int], part_names: list[str],
                 site_ids: list[int] | None = None):
        import mujoco

        self._mujoco = mujoco
        self.path = path
        self.label = label
        self.model = model
        self._data = mujoco.MjData(model)
        self.parts = part_names
        self._body_ids = np.array(body_ids, dtype=np.int64)
        self._site_ids = np.array(site_ids or [], dtype=np.int64)  # frames, after the bodies

        hinge, slide = int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)
        self.joints: list[JointInfo] = []
        adr: list[int] = []
        self._base_qpos = model.qpos0.copy()  # free / ball joints stay at their reference
        for i in range(model.njnt):
            jtype = int(model.jnt_type[i])
            if jtype not in (hinge, slide):
                continue  # free / ball: held at qpos0
            name = model.joint(i).name or _unnamed_joint(model, i)
            limited = bool(model.jnt_limited[i])
            lower, upper = (float(v) for v in model.jnt_range[i]) if limited else (None, None)
            kind = ("revolute" if limited else "continuous") if jtype == hinge else "prismatic"
            self.joints.append(JointInfo(name, kind, lower, upper))
            adr.append(int(model.jnt_qposadr[i]))
        self._qpos_adr = np.array(adr, dtype=np.int64)
        self._column = {info.name: k for k, info in enumerate(self.joints)}
        free = int(mujoco.mjtJoint.mjJNT_FREE)
        self._anchor = np.zeros((len(body_ids), 3))  # joint anchor in the body frame
        for k, b in enumerate(body_ids):
            count = int(model.body_jntnum[b])
            last = int(model.body_jntadr[b]) + count - 1
            if count and int(model.jnt_type[last]) != free:
                self._anchor[k] = model.jnt_pos[last]

    def pose_array(self, values: np.ndarray) -> np.ndarray:
        """(N, len(joints)) joint values in the order of ``joints`` -> (N, len(parts), 4, 4)."""
        values = np.atleast_2d(np.asarray(values, dtype=np.float64))
        n, ids, sites = len(values), self._body_ids, self._site_ids
        m, d = self.model, self._data
        kinematics = self._mujoco.mj_kinematics
        count = len(ids) + len(sites)
        xpos = np.empty((n, count, 3))
        xmat = np.empty((n, count, 9))
        for i in range(n):
            d.qpos[:] = self._base_qpos
            d.qpos[self._qpos_adr] = values[i]
            kinematics(m, d)
            xpos[i, :len(ids)] = d.xpos[ids]
            xmat[i, :len(ids)] = d.xmat[ids]
            xpos[i, len(ids):] = d.site_xpos[sites]
            xmat[i, len(ids):] = d.site_xmat[sites]
        out = np.zeros((n, count, 4, 4))
        out[..., :3, :3] = xmat.reshape(n, count, 3, 3)
        anchor = np.concatenate([self._anchor, np.zeros((len(sites), 3))])
        out[..., :3, 3] = xpos + np.einsum("npij,pj->npi", out[..., :3, :3], anchor)
        out[..., 3, 3] = 1.0
        return out

    def poses(self, q: dict[str, float]) -> dict[str, np.ndarray]:
        values = np.zeros(len(self.joints))
        for name, value in q.items():
            if name not in self._column:
                raise NameNotFoundError(f"{self.path}: no movable joint named {name!r} in MuJoCo's model")
            values[self._column[name]] = value
        return dict(zip(self.parts, self.pose_array(values)[0], strict=True))


def _urdf_has_world_link(path: Path) -> bool:
    """MuJoCo merges a URDF link named ``world`` into its world body (body 0)."""
    from lxml import etree

    try:
        root = etree.parse(str(path)).getroot()
    except etree.XMLSyntaxError:
        return False  # MuJoCo has already refused it, or will say why
    return root.find("link[@name='world']") is not None


def _mjcf_world_part(model) -> str | None:
    """The name of the root part our MJCF marks as MuJoCo's world body (text elements), or
    None when there is none."""
    import mujoco

    from ..formats.mjcf.conventions import WORLD, custom_name

    if mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_TEXT, custom_name(WORLD, "part")) < 0:
        return None
    named = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_TEXT, custom_name(WORLD, "name"))
    if named < 0:
        return WORLD
    adr, size = int(model.text_adr[named]), int(model.text_size[named])
    return bytes(model.text_data[adr:adr + size]).split(b"\0", 1)[0].decode("utf-8")


def _unnamed_joint(model, j: int) -> str:
    """An unnamed joint as the MJCF reader names it: ``<part>_joint``, its part the body's,
    or for a body's joint before its last the intermediate part ``<body>_joint_<k>``."""
    b = int(model.jnt_bodyid[j])
    body = model.body(b).name or f"body_{b}"
    k, count = j - int(model.body_jntadr[b]), int(model.body_jntnum[b])
    part = body if k == count - 1 else f"{body}_joint_{k}"
    return f"{part}_joint"


def _is_xacro(path: Path) -> bool:
    from ..formats.urdf.xacro_file import is_xacro

    return is_xacro(path)


def urdf_kinematics(path: Path) -> str:
    """The URDF's text without <visual>/<collision>: its kinematics and masses, which is
    all a kinematic reference needs (MuJoCo opens neither ``package://`` nor Collada); a
    <limit>'s missing bound written as the URDF specification's 0."""
    from lxml import etree

    from ..formats.urdf.structure import read_past
    from ..formats.urdf.xacro_file import document

    try:  # what MuJoCo's own XML parser reads past, as the URDF reader does
        root = read_past(document(path))[0]  # (a xacro file: the URDF it expands to)
    except etree.XMLSyntaxError as e:
        raise CheckError(f"{path}: MuJoCo refused it: malformed XML: {e}") from e
    for el in root.findall("link/visual") + root.findall("link/collision"):
        el.getparent().remove(el)
    # A <limit> with one bound: MuJoCo's import leaves the joint unlimited; the URDF
    # specification, urdfdom (ROS, Pinocchio) and our reader take the other bound as 0.
    for limit in root.findall("joint/limit"):
        given = [limit.get(a) is not None for a in ("lower", "upper")]
        if any(given) and not all(given):
            limit.set("upper" if given[0] else "lower", "0")
    return etree.tostring(root, encoding="unicode")


def source_urdf_spec(path: Path):
    """A user's URDF as MuJoCo imports it for a reference: its kinematics and masses
    (:func:`urdf_kinematics`), with MuJoCo's own repairs of bad inertia (``balanceinertia``,
    ``boundmass``, ``boundinertia``) as a user importing it into MuJoCo would set them."""
    import mujoco

    spec = mujoco.MjSpec.from_string(urdf_kinematics(path))
    spec.compiler.balanceinertia = True
    spec.compiler.boundmass = 1e-6
    spec.compiler.boundinertia = 1e-12
    return spec


def open_probes(path: str | Path, *, source: bool = False) -> list[MujocoProbe]:
    """``source``: the user's own file as the reference; a URDF is loaded for its kinematics
    (geometry removed) with MuJoCo's own repairs of bad inertia (``balanceinertia``,
    ``boundmass``, ``boundinertia``), as a user importing it into MuJoCo would set them."""
    import mujoco

    path = Path(path)
    is_urdf = format_for_path(path).name == "urdf"
    label = "MuJoCo (URDF)" if is_urdf else "MuJoCo (MJCF)"
    try:
        # qhull prints pages on a degenerate mesh; MuJoCo's own error says it in a line.
        with captured_c_output():
            # (a xacro file is read as the URDF it expands to, which MuJoCo cannot do)
            spec = source_urdf_spec(path) if is_urdf and (source or _is_xacro(path)) \
                else spec_from_file(path)
            # Every link/body must stay a body to be compared (MuJoCo's URDF default merges
            # bodies attached by fixed joints); visual-only geoms do not move anything.
            spec.compiler.fusestatic = False
            # (MuJoCo refuses to discard visual geoms that inertiafromgeom="true" weighs.)
            spec.compiler.discardvisual = spec.compiler.inertiafromgeom != \
                mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_TRUE
            try:
                model = spec.compile()
            except ValueError:
                if not is_urdf:
                    raise
                # MuJoCo computes every mesh's volume, and refuses a flat one (a floor, a
                # decal) that a URDF cannot mark as a shell; masses are not compared here.
                # (Only on refusal: meshes compiled as the file has them share MuJoCo's mesh
                # cache with the MJCF export of the same meshes, compiled once for both.)
                for mesh in spec.meshes:
                    mesh.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL
                model = spec.compile()
    except ValueError as e:
        # The error and the element it names come first; MuJoCo appends its warnings.
        lines = [line.strip() for line in str(e).splitlines() if line.strip()]
        message = "; ".join(lines[:2])
        if len(lines) > 2:
            message += f" (and {len(lines) - 2} more lines of MuJoCo warnings)"
        raise CheckError(f"{path}: MuJoCo refused it: {message}") from e

    # Contact exclusions move nothing either; without them the compiled model also serves
    # check's overlap measure, which counts every pair, instead of MuJoCo compiling the file
    # a second time.
    drop_exclusions(model)
    world = None if is_urdf else _mjcf_world_part(model)
    first = 0 if (_urdf_has_world_link(path) if is_urdf else world is not None) else 1
    body_ids = list(range(first, model.nbody))
    names = [model.body(i).name or f"body_{i}" for i in body_ids]  # as the MJCF reader names it
    if world is not None:
        names[0] = world
    # Named sites are frames (the MJCF reader's parts), unless a body has the name.
    site_ids = [s for s in range(model.nsite)
                if model.site(s).name and model.site(s).name not in names]
    names += [model.site(s).name for s in site_ids]
    return [MujocoProbe(path, label, model, body_ids, names, site_ids)]
