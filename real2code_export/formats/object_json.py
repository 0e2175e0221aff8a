"""object.json: the project's own lossless format.

A JSON document (schema name and version, the object, its parts and joints) with the
meshes beside it as OBJ files holding exact float64 text, each distinct mesh once (a mesh
asset placed several times is one file, each placement an entry with its pose:
``meshfiles.MeshLayout``). Transforms are stored as a
translation and a 3x3 rotation matrix, numbers as Python's shortest exact text, so
load(save(obj)) reproduces ``obj`` bit for bit.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from .. import atomic
from .. import transforms as tf
from ..errors import FormatError, ModelError
from ..meshfiles import (
    MeshGeometry,
    MeshLayout,
    map_relpath,
    read_mesh,
    texture_from_file,
    texture_relpath,
    write_object_meshes,
)
from ..model import (
    PBR_MAPS,
    ArticulatedObject,
    DriveLimits,
    Dynamics,
    Inertial,
    Joint,
    JointType,
    Limits,
    Mesh,
    Part,
    validate,
)
from ..model_json import (
    choice,
    drive_from_json,
    drive_json,
    member,
    mimic_from_json,
    mimic_json,
    number,
    shape_from_json,
    shape_json,
    transform,
    vector,
)

SCHEMA = "real2code_export/object"
# 2: a mesh file placed at a pose ({"mesh", "pose"}: a mesh asset written once, placed by
# several parts or several times in one); version 1 files read as they are.
SCHEMA_VERSION = 2
READS = (1, 2)
FILENAME = "object.json"


def _placed(g: MeshGeometry, shared: dict[str, str]) -> dict | str:
    """A mesh file entry: its path (the first file holding the same mesh), or where it is
    placed, {"mesh", "pose"}."""
    if g.pose is None:
        return shared[g.relpath]
    return {"mesh": shared[g.relpath], "pose": {"translation": g.pose[:3, 3].tolist(),
                                        "rotation": g.pose[:3, :3].tolist()}}


def _visual_files(part: Part, layout: MeshLayout,
                  shared: dict[str, str]) -> str | list[dict] | None:
    """The visual's mesh file, or for a visual of several colours or placed meshes each
    colour's or placement's file ({"mesh", "color", "pose"})."""
    files = layout.visuals[part.name]
    several = part.visual is not None and bool(part.visual.colors)
    if not several and len(files) == 1 and files[0].pose is None:
        return shared[files[0].relpath]
    if not files:
        return None
    entries = [_placed(g, shared) for g in files]
    return [(e if isinstance(e, dict) else {"mesh": e})
            | ({"color": list(g.rgba)} if several else {})
            for e, g in zip(entries, files, strict=True)]


def to_dict(obj: ArticulatedObject) -> dict[str, Any]:
    parts, layout = [], MeshLayout(obj)
    shared = layout.shared_files()  # equal meshes: one file
    for p in obj.parts:
        meshes = dict(layout.collisions[p.name])
        parts.append(
            {
                "name": p.name,
                "color": list(p.color),
                # a visual of several colours: a file per colour ({"mesh", "color"}), its
                # shapes' colours beside them
                "visual": _visual_files(p, layout, shared),
                **({"visual_shapes": [shape_json(s) for s in p.visual.primitives]}
                   if p.visual is not None and p.visual.primitives else {}),
                **({"visual_shape_colors": [list(c) for c in p.visual.shape_colors()]}
                   if p.visual is not None and p.visual.colors and p.visual.primitives
                   else {}),
                "texture": texture_relpath(p) if p.texture is not None else None,
                **({"maps": {role: map_relpath(p, role) for role in p.maps}} if p.maps else {}),
                "collision": [_placed(meshes[k], shared) if m.primitive is None
                              else {"shape": shape_json(m.primitive)}
                              for k, m in enumerate(p.collision)],
                "inertial": None
                if p.inertial is None
                else {
                    "mass": p.inertial.mass,
                    "com": p.inertial.com.tolist(),
                    "inertia": p.inertial.inertia.tolist(),
                },
            }
        )
    joints = []
    for j in obj.joints:
        joints.append(
            {
                "name": j.name,
                "type": j.type.value,
                "parent": j.parent,
                "child": j.child,
                "origin": {
                    "translation": j.origin[:3, 3].tolist(),
                    "rotation": j.origin[:3, :3].tolist(),
                },
                "axis": j.axis.tolist(),
                "limits": None
                if j.limits is None
                else {
                    "lower": j.limits.lower,
                    "upper": j.limits.upper,
                    "effort": j.limits.effort,
                    "velocity": j.limits.velocity,
                },
                "dynamics": {
                    "damping": j.dynamics.damping,
                    "friction": j.dynamics.friction,
                    "stiffness": j.dynamics.stiffness,
                    "spring_ref": j.dynamics.spring_ref,
                    "armature": j.dynamics.armature,
                },
                "state": j.state,
                **({} if j.mimic is None else {"mimic": mimic_json(j.mimic)}),
                **({} if j.drive_limits is None else {"drive_limits": {
                    "effort": j.drive_limits.effort, "velocity": j.drive_limits.velocity}}),
                **({} if j.cone_limit is None else {"cone_limit": j.cone_limit}),
                **({} if j.drive is None else {"drive": drive_json(j.drive)}),
            }
        )
    return {
        "schema": SCHEMA,
        "schema_version": SCHEMA_VERSION,
        "name": obj.name,
        "metadata": obj.metadata,
        "parts": parts,
        "joints": joints,
    }


def dumps(obj: ArticulatedObject) -> str:
    # allow_nan=False: the model is validated finite; a NaN here is a bug, not data.
    return json.dumps(to_dict(obj), indent=1, allow_nan=False) + "\n"


def save(obj: ArticulatedObject, out_dir: str | Path, *, write_meshes: bool = True,
         filename: str = FILENAME) -> Path:
    """Write ``out_dir/object.json`` and its meshes (call inside a staged output for a set)."""
    validate(obj)
    out_dir = Path(out_dir)
    if write_meshes:
        write_object_meshes(obj, out_dir, exact=True)
    return atomic.write_text(out_dir / filename, dumps(obj))


# -- load ------------------------------------------------------------------------------------
def from_dict(data: dict[str, Any], path: Path) -> ArticulatedObject:
    base = path.parent
    if not isinstance(data, dict) or data.get("schema") != SCHEMA:
        raise FormatError(path, None, f"not a real2code_export object (schema must be {SCHEMA!r})")
    version = data.get("schema_version")
    if version not in READS:
        raise FormatError(path, "schema_version", f"unsupported version {version!r} "
                          f"(this release reads {', '.join(map(str, READS))})")
    assets: dict[str, Mesh] = {}  # a file placed several times is one asset

    def mesh_file(item: Any, el: str) -> Mesh:
        """A mesh file entry (a path, or {"mesh", "pose"}) as the mesh it places."""
        rel = member(item, "mesh", path, el) if isinstance(item, dict) else item
        if not isinstance(rel, str):
            raise FormatError(path, el, f"a mesh file must be a path, got {rel!r}")
        if not isinstance(item, dict) or item.get("pose") is None:
            return read_mesh(base / rel, source=path, element=el)
        if rel not in assets:
            assets[rel] = read_mesh(base / rel, source=path, element=el)
        pose = transform(item["pose"], path, el, "pose ")
        if not tf.is_rotation(pose[:3, :3]):
            raise FormatError(path, el, "pose rotation is not a rotation matrix")
        return Mesh.placed(assets[rel], pose)

    parts = []
    for i, pd in enumerate(member(data, "parts", path, "object")):
        el = f"parts[{i}]"
        name = member(pd, "name", path, el)
        el = f"part {name!r}"
        visuals, colours = [], []
        files = pd.get("visual")
        for k, item in enumerate(files if isinstance(files, list) else
                                 [] if files is None else [{"mesh": files}]):
            visuals.append(mesh_file(item, f"{el} visual" + (f"[{k}]" if isinstance(
                files, list) else "")))
            colours.append(item.get("color") if isinstance(item, dict) else None)
        visuals += [Mesh.of_primitive(shape_from_json(d, path, f"{el} visual_shapes[{k}]"))
                    for k, d in enumerate(pd.get("visual_shapes", []))]
        colours += pd.get("visual_shape_colors") or [None] * (len(visuals) - len(colours))
        if not visuals or None in colours or len(colours) != len(visuals):
            visual = (visuals[0] if len(visuals) == 1 else Mesh.concatenate(visuals)) \
                if visuals else None
        else:  # a visual of several colours
            visual = Mesh.concatenate(visuals, [tuple(vector(c, 4, path, el, "visual color"))
                                                for c in colours])
        collision = [
            Mesh.of_primitive(shape_from_json(rel["shape"], path, f"{el} collision[{k}]"))
            if isinstance(rel, dict) and "shape" in rel
            else mesh_file(rel, f"{el} collision[{k}]")
            for k, rel in enumerate(pd.get("collision", []))
        ]
        inertial = None
        if pd.get("inertial") is not None:
            ind = pd["inertial"]
            inertial = Inertial(
                mass=number(member(ind, "mass", path, el), path, el, "mass"),
                com=vector(member(ind, "com", path, el), 3, path, el, "com"),
                inertia=vector(member(ind, "inertia", path, el), 9, path, el, "inertia").reshape(3, 3),
            )
        color = tuple(vector(pd.get("color", [0.7, 0.7, 0.7, 1.0]), 4, path, el, "color"))
        images = {"texture": pd.get("texture")}
        maps = pd.get("maps") or {}
        if not isinstance(maps, dict) or not set(maps) <= set(PBR_MAPS):
            raise FormatError(path, el + " maps", f"must map some of {', '.join(PBR_MAPS)} "
                              "to image files")
        images |= maps
        read = {}
        for role, relpath in images.items():
            if relpath is None:
                continue
            image = base / relpath
            if not image.is_file():
                raise FormatError(path, f"{el} {role}", f"image file not found: {image}")
            if visual is None or visual.uv is None:
                raise FormatError(path, f"{el} {role}", "needs a visual mesh with texture "
                                  "coordinates (vt in its OBJ)")
            read[role] = texture_from_file(image)
        texture = read.pop("texture", None)
        parts.append(Part(name=name, visual=visual, collision=collision, inertial=inertial,
                          color=color, texture=texture, maps=read))
    joints = []
    for i, jd in enumerate(member(data, "joints", path, "object")):
        el = f"joints[{i}]"
        name = member(jd, "name", path, el)
        el = f"joint {name!r}"
        jtype = choice(jd, "type", JointType, path, el, "joint type")
        od = member(jd, "origin", path, el)
        origin = transform(od, path, el, "origin ")
        limits = None
        if jd.get("limits") is not None:
            ld = jd["limits"]
            limits = Limits(
                lower=number(member(ld, "lower", path, el), path, el, "lower limit"),
                upper=number(member(ld, "upper", path, el), path, el, "upper limit"),
                effort=None if ld.get("effort") is None else number(ld["effort"], path, el, "effort"),
                velocity=None if ld.get("velocity") is None
                else number(ld["velocity"], path, el, "velocity"),
            )
        drive = jd.get("drive_limits")
        drive_limits = None if drive is None else DriveLimits(**{
            k: None if drive.get(k) is None else number(drive[k], path, el, f"{k} limit")
            for k in ("effort", "velocity")})
        dd = jd.get("dynamics") or {}
        dynamics = Dynamics(**{
            k: number(dd.get(k, 0.0), path, el, k)
            for k in ("damping", "friction", "stiffness", "spring_ref", "armature")
        })
        joints.append(Joint(
            name=name, type=JointType(jtype), parent=member(jd, "parent", path, el),
            child=member(jd, "child", path, el), origin=origin,
            axis=vector(jd.get("axis", [0, 0, 1]), 3, path, el, "axis"), limits=limits,
            dynamics=dynamics, state=number(jd.get("state", 0.0), path, el, "state"),
            mimic=None if jd.get("mimic") is None else mimic_from_json(jd["mimic"], path, el),
            drive_limits=drive_limits,
            cone_limit=None if jd.get("cone_limit") is None
            else number(jd["cone_limit"], path, el, "cone limit"),
            drive=None if jd.get("drive") is None else drive_from_json(jd["drive"], path, el),
        ))
    obj = ArticulatedObject(name=member(data, "name", path, "object"), parts=parts, joints=joints,
                            metadata=dict(data.get("metadata") or {}))
    try:
        return validate(obj)
    except ModelError as e:
        raise FormatError(path, e.element, e.message) from e


def load(path: str | Path) -> ArticulatedObject:
    path = Path(path)
    if not path.is_file():
        raise FormatError(path, None, "file not found")
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError) as e:
        line = getattr(e, "lineno", None)
        raise FormatError(path, None, f"malformed JSON: {getattr(e, 'msg', e)}", line) from e
    return from_dict(data, path)


