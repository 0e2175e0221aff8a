"""ArticulatedObject -> MjSpec -> MJCF text, compiled by MuJoCo before anything is kept.

One body per part, named as the part, posed at its joint origin; the joint (hinge, slide or
ball) at the body origin; the root a jointless child of the world (fixed base), or the world
body itself when it is named ``world`` or a floating joint (a free joint) hangs from it; a
fixed joint a jointless nested body (a frame, with no mass, geometry or children, a site); the
intermediate parts the reader makes for a body with several joints merged back into it
(:mod:`.structure`); a mimic a joint equality. Each body has its explicit
inertial (``fullinertia``), a non-colliding visual mesh geom (group 2, the part colour) and
one colliding mesh geom per convex piece (group 3); shapes (box, cylinder, ...) are geoms of
their type. A joint's drive is an actuator (:mod:`.actuator`); the actuators, tendons, sensors
and equalities an MJCF reader kept in the metadata are written back where MuJoCo compiles them
(:mod:`.kept`), the drives among the actuators where the file read had them. Every parent/child pair is excluded from
contact. Every hinge and slide has ``ref`` = its state and its body is written at that pose, so
that MuJoCo starts there (qpos0) and joint values mean the same as in the model
(:func:`_placed_joints`). What MJCF has no place for is kept in the keyframe "observed" (the
joint states again, for a reader that looks there) and in ``<custom>`` data named
``real2code:<element>:<field>`` (velocity limits, fixed-joint names, metadata, ...).
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np

from ... import atomic, meshcache
from ... import transforms as tf
from ...engine_settings import (
    FRICTION_SOLREF,
    LIMIT_MARGIN,
    LIMIT_SOLIMP,
    LIMIT_SOLREF,
    MULTICCD,
)
from ...errors import ExportError, warn
from ...meshfiles import (
    MESH_DIR,
    MeshLayout,
    image_textures,
    map_relpath,
    texture_relpath,
    visual_element_name,
    write_object_meshes,
)
from ...model import (
    ArticulatedObject,
    Joint,
    JointType,
    Part,
    Texture,
    metadata_json,
    validate,
)
from .. import output_file
from .conventions import (
    COLLISION_GROUP,
    KEYFRAME,
    METADATA,
    VISUAL_GROUP,
    WORLD,
    custom_name,
    describe_mujoco_error,
    float32,
    snap_position,
    snap_unit,
)
from .geometry import mjcf_geom
from .kept import ELEMENTS_KEY, restore, without_files
from .structure import anchors, body_chains, site_parts

# MuJoCo 4.0.0 leaves out an inertial pos of zero when it writes a spec as authored, and its
# own parser then refuses the file (the attribute is required): it is put back.
_INERTIAL_WITHOUT_POS = re.compile(r"<inertial (?![^>]*\bpos=)")
_COMPILER = re.compile(r"<compiler\b[^>]*/>")


def save(obj: ArticulatedObject, out_dir: str | Path, *, write_meshes: bool = True) -> Path:
    """Write ``out_dir/<obj.name>.xml`` (and, if ``write_meshes``, the shared mesh files).

    MuJoCo compiles the model, reading the mesh files the XML references, before the XML is
    written; if it refuses, :class:`ExportError` names the part or joint and nothing is left
    behind. Without ``write_meshes`` the mesh files must already be in ``out_dir`` (as
    :func:`real2code_export.formats.export` writes them).
    """
    validate(obj)
    for part in obj.parts:
        if "metallic_roughness" in part.maps and not _orm(part):
            warn(f"MJCF: part {part.name!r}: its metallic_roughness map is not used by the MJCF "
                 "file (MuJoCo packs it with occlusion, in R, as one ORM image); the image is "
                 "written beside the meshes")
    out_dir = Path(out_dir)
    if not write_meshes:
        return _write_xml(obj, out_dir)
    # The meshes are staged with the XML, so a refused model leaves neither behind, and each
    # file is written once: the compiler reads the very files the XML references.
    with atomic.staged_output(out_dir) as staging:
        write_object_meshes(obj, staging)
        _write_xml(obj, staging)
    return output_file("mjcf", out_dir, obj.name)


def build_spec(obj: ArticulatedObject, *, mesh_dir: Path | None = None):
    """The model as a ``mujoco.MjSpec`` that compiles as it is (calibration simulates it,
    tests compile it).

    Without ``mesh_dir`` the meshes are given as vertices and faces, so nothing needs to be
    on disk (and :func:`to_xml` of that spec holds them inline); with it, they are the files
    in that folder (the ``meshes`` folder of an export), as in the saved XML.
    """
    validate(obj)
    if mesh_dir is None:
        return _build(obj, meshdir=MESH_DIR, in_memory=True)
    return _build(obj, meshdir=str(Path(mesh_dir).resolve()))


def to_xml(spec, obj: ArticulatedObject) -> str:
    """MJCF text of a spec made by :func:`build_spec` (MuJoCo compiles it first)."""
    try:
        text = spec.to_xml()
    except ValueError as e:
        message, name, _tag, _line = describe_mujoco_error(str(e))
        where = _element_owner(obj, name) if name is not None else f"object {obj.name!r}"
        raise ExportError(f"MJCF: MuJoCo refused {where}: {message}") from e
    text = _INERTIAL_WITHOUT_POS.sub('<inertial pos="0 0 0" ', text)
    return _text_as_attribute(_with_multiccd(text))


def _with_multiccd(text: str) -> str:
    """``<option><flag multiccd="enable"/></option>`` written out although it is MuJoCo's
    default (which MuJoCo's writer leaves out): Newton's MuJoCo solver turns it off unless the
    file says so (engine_settings.MULTICCD)."""
    value = "enable" if MULTICCD else "disable"
    compiler = _COMPILER.search(text)
    if "<option" not in text and compiler is not None:  # MuJoCo's output: no parse needed
        at = compiler.end()
        return f'{text[:at]}\n\n  <option>\n    <flag multiccd="{value}"/>\n  </option>{text[at:]}'
    from lxml import etree

    root = etree.fromstring(text.encode("utf-8"))
    option = root.find("option")
    if option is None:
        option = etree.Element("option")
        root.insert(0, option)
    flag = option.find("flag")
    if flag is None:
        flag = etree.SubElement(option, "flag")
    flag.set("multiccd", value)
    return etree.tostring(root, encoding="unicode") + "\n"


def _text_as_attribute(text: str) -> str:
    """``<text name="..."><![CDATA[...]]></text>`` (MuJoCo's output) as ``<text name="..."
    data="..."/>``: XML tools that rewrite a file turn CDATA into text content, which MuJoCo
    then refuses ("text field cannot be empty"); an attribute survives every rewrite."""
    if "<![CDATA[" not in text:
        return text
    from lxml import etree

    root = etree.fromstring(text.encode("utf-8"))
    for element in root.iter("text"):
        if element.text is not None and element.get("data") is None:
            element.set("data", element.text)
            element.text = None
    return etree.tostring(root, encoding="unicode") + "\n"


def _write_xml(obj: ArticulatedObject, out_dir: Path) -> Path:
    _write_png_copies(obj, out_dir)
    spec = _build(obj, meshdir=MESH_DIR, model_dir=out_dir)
    _images_not_decoded(spec, obj)
    text = to_xml(spec, obj)
    sections = obj.metadata.get(ELEMENTS_KEY)
    sections = sections if isinstance(sections, dict) else {}
    if sections or any(j.drive is not None for j in obj.joints):
        text = _with_kept(obj, text, with_drives(obj, sections), out_dir)
    return atomic.write_text(output_file("mjcf", out_dir, obj.name), text)


def _with_kept(obj: ArticulatedObject, text: str, sections: dict, out_dir: Path) -> str:
    """The file with the MJCF sections a reader kept (actuators, tendons, sensors,
    equalities, their default classes) written back where MuJoCo compiles them; what it
    refuses stays in the metadata, warned about."""
    import mujoco

    def compiles(candidate: str) -> None:  # (the model itself compiled already)
        spec = mujoco.MjSpec.from_string(candidate)
        spec.modelfiledir = str(out_dir) + "/"
        spec.compile()

    bad = [tag for tag, v in sections.items() if not isinstance(v, str)]
    if bad:
        raise ExportError(f"MJCF: object {obj.name!r} metadata {ELEMENTS_KEY!r}: sections "
                          f"{bad} are not XML text")
    text, left, why = restore(text, sections, compiles, without_files(text))
    for reason in why:
        warn(f"MJCF: object {obj.name!r}: kept MJCF element not written back (it stays in "
             f"the metadata {ELEMENTS_KEY!r}): {reason}")
    metadata = {k: v for k, v in obj.metadata.items() if k != ELEMENTS_KEY}
    if left:
        metadata[ELEMENTS_KEY] = left
    return _replace_metadata(text, metadata)


def with_drives(obj: ArticulatedObject, sections: dict) -> dict:
    """The kept sections with the model's drives as actuators in the ``actuator`` section:
    each at its marker (where the file it was read from had it), the rest first, in joint
    order; a marker of a joint without a drive is left out."""
    from lxml import etree

    from .actuator import actuator_element
    from .kept import drive_of_marker

    driven = {j.name: j.drive for j in obj.joints if j.drive is not None}
    kept = sections.get("actuator")
    if not driven or (kept is not None and not isinstance(kept, str)):
        return sections  # (a section that is not text: refused with the others)
    section = etree.Element("actuator") if kept is None else etree.fromstring(kept)
    placed = set()
    for el in list(section):
        if isinstance(el.tag, str):
            continue
        joint = drive_of_marker(el.text or "")
        if joint is not None and joint in driven and joint not in placed:
            section.replace(el, actuator_element(driven[joint], joint))
            placed.add(joint)
        else:
            section.remove(el)
    for at, joint in enumerate(j for j in driven if j not in placed):
        section.insert(at, actuator_element(driven[joint], joint))
    etree.indent(section, space="  ")
    return {**sections, "actuator": etree.tostring(section, encoding="unicode")}


def _replace_metadata(text: str, metadata: dict) -> str:
    """The file with its metadata text (or none, for empty metadata) replaced."""
    import json

    from lxml import etree

    root = etree.fromstring(text.encode("utf-8"))
    element = root.find(f"custom/text[@name='{METADATA}']")
    if element is not None and not metadata:
        element.getparent().remove(element)
    elif element is not None:
        element.set("data", json.dumps(metadata, sort_keys=True, separators=(",", ":"),
                                       allow_nan=False))
    return etree.tostring(root, encoding="unicode") + "\n"


# -- the spec ---------------------------------------------------------------------------------
def _build(obj: ArticulatedObject, *, meshdir: str, in_memory: bool = False,
           model_dir: Path | None = None):
    import mujoco

    spec = mujoco.MjSpec()
    spec.modelname = obj.name
    compiler = spec.compiler
    compiler.degree = False  # MjSpec defaults to degrees; the model is in radians
    compiler.autolimits = True
    compiler.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_FALSE
    # validate() accepts A + B >= C up to 1e-9 (rounding); MuJoCo accepts no shortfall at all.
    compiler.balanceinertia = True
    # Save what the spec holds, every number at full precision (compiled values are printed
    # with 6 digits), fullinertia as written.
    compiler.savecompiled = False
    compiler.savecanonical = False
    spec.meshdir = meshdir
    if any(part.texture is not None or part.maps for part in obj.parts):
        spec.texturedir = meshdir  # images lie beside the meshes (meshfiles.texture_relpath)
    # Limits and dry friction as the other engines have them (engine_settings.py).
    spec.default.joint.solref_limit = list(LIMIT_SOLREF)
    spec.default.joint.solimp_limit = list(LIMIT_SOLIMP)
    spec.default.joint.solref_friction = list(FRICTION_SOLREF)
    spec.default.joint.margin = LIMIT_MARGIN
    if model_dir is not None:
        spec.modelfiledir = str(model_dir) + "/"

    parts = obj.parts_in_tree_order()
    # One asset per distinct mesh file (MeshLayout: a mesh asset placed several times is one
    # file; geoms whose meshes are equal share the first one's), so MuJoCo compiles each
    # once. A visual's shell inertia only where no collision geom uses the asset: then the
    # asset is what a URDF of the same meshes gives MuJoCo (its mesh cache serves both), and
    # with inertiafromgeom off the mode only places the mesh in its geom.
    layout = MeshLayout(obj)
    shared = layout.shared_files()
    colliding = {shared[g.relpath] for part in parts for g, visual in layout.geometries(part)
                 if not visual}
    declared = set()
    textures_declared: set[str] = set()  # (texture assets: _add_material)
    for part in parts:
        for g, visual in layout.geometries(part):
            rel = g.relpath
            if shared[rel] != rel or rel in declared:
                continue
            declared.add(rel)  # (an asset placed several times: one <mesh>)
            if in_memory:  # user vertices: no file, no text to format and parse
                asset = spec.add_mesh(name=_stem(rel))
                asset.uservert = g.mesh.vertices.ravel()
                asset.userface = g.mesh.faces.astype(np.int32).ravel()
            else:
                asset = spec.add_mesh(name=_stem(rel), file=rel.removeprefix(MESH_DIR + "/"))
            if visual and rel not in colliding:  # scans are often open or flat: an area
                asset.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL
        # (in memory, for kinematics and dynamics only, no image is needed: none is added)
        if (part.texture is not None or part.maps) and not in_memory:
            _add_material(spec, part, textures_declared)

    joints = list(obj.joints_in_tree_order())
    root = obj.root
    if root_is_world(obj):  # MuJoCo's own world body is that part (its mass in <custom>)
        bodies = {root.name: spec.worldbody}
        _add_geoms(spec.worldbody, root, layout)
    else:
        bodies = {root.name: _add_body(spec.worldbody, root, None, layout)}
    sites, chains, parts_by_name = site_parts(obj), body_chains(obj), obj.tree().parts
    merged = {j.child for chain in chains.values() for j in chain[:-1]}
    refs = {j.name: j.state for j in joints if not j.type.multi_dof}  # a joint's ref
    for joint in joints:
        if joint.child in sites:  # a frame: a site of its parent's body
            _add_site(bodies[joint.parent], joint)
        elif joint.parent not in merged:  # (the rest of a chain is its first joint's body)
            chain = chains.get(joint.name, [joint])
            body = _add_body(bodies[joint.parent], parts_by_name[chain[-1].child], chain,
                             layout)
            bodies.update((j.child, body) for j in chain)
    assets = {_stem(rel): _stem(first) for rel, first in shared.items()}
    for geom in spec.geoms:
        if geom.meshname in assets:
            geom.meshname = assets[geom.meshname]
    for part in parts:
        if (part.texture is not None or part.maps) and not in_memory:
            spec.geom(f"{part.name}_visual").material = texture_name(part)
    for joint in joints:  # explicit, not only MuJoCo's parent filter (fixed joints included)
        if joint.child not in sites and bodies[joint.parent] is not bodies[joint.child]:
            spec.add_exclude(bodyname1=bodies[joint.parent].name,
                             bodyname2=bodies[joint.child].name)
    for joint in joints:  # y - y0 = a0 + a1 (x - x0), y0 and x0 the joints' qpos0 (refs)
        if joint.mimic is not None:
            m = joint.mimic
            offset = m.offset + m.multiplier * refs.get(m.joint, 0.0) - refs.get(joint.name, 0.0)
            spec.add_equality(type=mujoco.mjtEq.mjEQ_JOINT, objtype=mujoco.mjtObj.mjOBJ_JOINT,
                              name1=joint.name, name2=m.joint,
                              data=[offset, m.multiplier] + [0.0] * 10)
    _add_custom(spec, obj, [p for p in parts if p.name not in merged], joints)
    qpos = [x for j in joints for x in _qpos(j)]
    if qpos:  # bodies, hence qpos, are in this same depth-first order
        spec.add_key(name=KEYFRAME, qpos=qpos)
    return spec


def _add_site(body, joint: Joint) -> None:
    body.add_site(name=joint.child, pos=[x + 0.0 for x in joint.origin[:3, 3]],
                  quat=snap_unit(tf.matrix_to_quat(joint.origin[:3, :3]), sign_free=True))


def root_is_world(obj: ArticulatedObject) -> bool:
    """The root part is written as MuJoCo's world body when it is named so, or when a floating
    joint hangs from it (MuJoCo's free joints hang from the world body only)."""
    return obj.root.name == WORLD or any(j.type is JointType.FLOATING for j in obj.joints)


def _qpos(joint: Joint) -> list[float]:
    """The joint's coordinates in the keyframe: its state, or the reference pose of a ball
    (the identity) or free joint (the body's pose in the world, as qpos0 holds it)."""
    if joint.type is JointType.BALL:
        return [1.0, 0.0, 0.0, 0.0]
    if joint.type is JointType.FLOATING:
        quat = snap_unit(tf.matrix_to_quat(joint.origin[:3, :3]), sign_free=True)
        return [x + 0.0 for x in joint.origin[:3, 3]] + quat
    return [joint.state] if joint.type.movable else []


def _add_material(spec, part: Part, declared: set[str]) -> None:
    """A material on the part's images: the colour image in the RGB role (the part's colour a
    tint, as glTF's factor is), and the maps in MuJoCo's layer roles: normal, occlusion,
    emissive, and glTF's metallic-roughness map as ORM where the occlusion map is that same
    image (glTF's packing: occlusion R, roughness G, metallic B). MuJoCo reads the texture
    coordinates from the OBJ."""
    import mujoco

    role = mujoco.mjtTextureRole
    linear, srgb = mujoco.mjtColorSpace.mjCOLORSPACE_LINEAR, mujoco.mjtColorSpace.mjCOLORSPACE_SRGB
    images = _mujoco_images(part)
    layers = []  # (MuJoCo role, image file, colour space)
    if part.texture is not None:
        layers.append((role.mjTEXROLE_RGB, images[texture_relpath(part)], srgb))
    for ours, theirs, space in (("normal", role.mjTEXROLE_NORMAL, linear),
                                ("occlusion", role.mjTEXROLE_OCCLUSION, linear),
                                ("emissive", role.mjTEXROLE_EMISSIVE, srgb)):
        if ours in part.maps:
            layers.append((theirs, images[map_relpath(part, ours)], space))
    if _orm(part):
        layers.append((role.mjTEXROLE_ORM, images[map_relpath(part, "occlusion")], linear))
    material = spec.add_material(name=texture_name(part), rgba=float32(part.color))
    textures = list(material.textures)
    for theirs, relpath, space in layers:
        # one texture asset per file and colour space, whichever parts show it: MuJoCo
        # decodes each asset when it compiles (a robot's four legs: one image, not four)
        name = _stem(relpath) + ("_linear" if space == linear else "")
        if name not in declared:
            spec.add_texture(name=name, type=mujoco.mjtTexture.mjTEXTURE_2D, colorspace=space,
                             file=relpath.removeprefix(MESH_DIR + "/"))
            declared.add(name)
        textures[theirs] = name
    material.textures = textures


def _mujoco_images(part: Part) -> dict[str, str]:
    """The shared image file (``meshfiles.image_textures``) -> the file MuJoCo reads: the same,
    or for a JPEG (which MuJoCo cannot decode) a PNG of its pixels beside it."""
    return {rel: (str(Path(rel).with_suffix(".png")) if texture.mime == "image/jpeg" else rel)
            for rel, texture in image_textures(part).items()}


def _write_png_copies(obj: ArticulatedObject, out_dir: Path) -> None:
    """The PNG that MuJoCo reads for each JPEG image (pixels as Pillow decodes the JPEG, which
    is what every reader of the shared file shows). Encoding is most of a textured export's
    cost (a robot's 2048-pixel photos: 0.1 s each), so the copies are encoded side by side
    (Pillow's encoder leaves the interpreter lock) and kept in the disk cache by the JPEG's
    digest (:func:`meshcache.cached_bytes`): exporting the same file again encodes nothing."""
    from concurrent.futures import ThreadPoolExecutor

    copies = {}  # PNG file -> its JPEG (an image several parts show: one copy)
    for part in obj.parts:
        textures = image_textures(part)
        for rel, png in _mujoco_images(part).items():
            if png != rel:
                copies.setdefault(png, textures[rel])
    if not copies:
        return
    with ThreadPoolExecutor(min(len(copies), os.cpu_count() or 1)) as pool:
        encoded = list(pool.map(_png_copy, copies.values()))
    for png, data in zip(copies, encoded, strict=True):
        atomic.write_bytes(out_dir / png, data)


def _png_copy(jpeg: Texture) -> bytes:
    import PIL

    def encode() -> bytes:
        from io import BytesIO

        from PIL import Image

        buffer = BytesIO()
        # (zlib's fastest level: a copy for MuJoCo only; 2x quicker than the default, a
        # third larger)
        Image.open(BytesIO(jpeg.image)).save(buffer, format="PNG", compress_level=1)
        return buffer.getvalue()

    return meshcache.cached_bytes("mujoco_png", jpeg.digest, {"pillow": PIL.__version__},
                                  encode, sources=[__file__])


# A 1-pixel PNG: what MuJoCo is given for each image while it compiles the spec to write it.
_PLACEHOLDER_PNG = bytes.fromhex(
    "89504e470d0a1a0a0000000d4948445200000001000000010802000000907753de0000000c4944415478"
    "9c63f8ffff3f0005fe02fe0def46b80000000049454e44ae426082")


def _images_not_decoded(spec, obj: ArticulatedObject) -> None:
    """MuJoCo compiles a spec before it writes its XML, decoding every image a texture names,
    though nothing it writes depends on their pixels (a file name is written as given): a
    second of a textured robot's export. Each texture file is given to that compile as a
    1-pixel PNG from memory (``MjSpec.assets``, which MuJoCo reads before any file). What
    the compile proved of the images, that each is a PNG MuJoCo reads, is checked here
    instead: every PNG MuJoCo will read from the export is whole (Pillow's ``verify``: its
    chunks and their checksums; the copies of JPEGs are Pillow's own PNG)."""
    if not spec.textures:
        return
    from io import BytesIO

    from PIL import Image

    for part in obj.parts:
        for rel, texture in image_textures(part).items():
            if texture.mime != "image/png":
                continue
            try:
                Image.open(BytesIO(texture.image)).verify()
            except Exception as e:  # Pillow raises many types for a broken image
                raise ExportError(f"MJCF: part {part.name!r}: image {texture.name!r} "
                                  f"({rel}): not a PNG MuJoCo can read: {e}") from e
    spec.assets = {texture.file: _PLACEHOLDER_PNG for texture in spec.textures if texture.file}


def _orm(part: Part) -> bool:
    """Whether glTF's metallic-roughness map is the occlusion map too (MuJoCo's ORM)."""
    maps = part.maps
    return "metallic_roughness" in maps and "occlusion" in maps \
        and maps["metallic_roughness"].image == maps["occlusion"].image


def texture_name(part: Part) -> str:
    """The texture asset's and its material's name."""
    return f"{part.name}_texture"


def _stem(relpath: str) -> str:
    """The mesh asset's name: its file name without folder and extension."""
    return relpath.rpartition("/")[2].rpartition(".")[0]


def _add_body(parent, part: Part, chain: list[Joint] | None, layout: MeshLayout):
    """The part's body, placed by the joint into it, or by a chain of joints that MJCF holds
    in one body, at the joints' states (:func:`_placed_joints`)."""
    if chain is None:
        body = parent.add_body(name=part.name)
    else:
        pose, placed = _placed_joints(chain)
        rotation = tf.matrix_to_quat(pose[:3, :3])
        body = parent.add_body(name=part.name, pos=[x + 0.0 for x in pose[:3, 3]],
                               quat=snap_unit(rotation, sign_free=True))
        for joint, anchor, axis in placed:
            if joint.type is not JointType.FIXED:
                _add_joint(body, joint, anchor, axis)
    if part.inertial is not None:
        body.explicitinertial = True
        body.mass = part.inertial.mass
        body.ipos = [x + 0.0 for x in part.inertial.com]
        body.fullinertia = full_inertia(part.inertial.inertia)
    _add_geoms(body, part, layout)
    return body


def full_inertia(inertia) -> list[float]:
    """MJCF's fullinertia order: ixx iyy izz ixy ixz iyz."""
    return [inertia[0, 0], inertia[1, 1], inertia[2, 2], inertia[0, 1], inertia[0, 2],
            inertia[1, 2]]


def _add_geoms(body, part: Part, layout: MeshLayout) -> None:
    import mujoco

    mesh_geom = mujoco.mjtGeom.mjGEOM_MESH
    rgba = float32(part.color)
    visual_only = dict(contype=0, conaffinity=0, group=VISUAL_GROUP)
    # a visual of several colours or placed meshes: a geom per colour or placement, the
    # first named as a visual of one mesh
    for g in layout.visuals[part.name]:
        body.add_geom(name=g.name, type=mesh_geom, meshname=_stem(g.relpath),
                      rgba=float32(g.rgba), **_placed(g.pose), **visual_only)
    shapes = part.visual.primitives if part.visual is not None else ()
    for k, (shape, colour) in enumerate(zip(shapes, part.visual.shape_colors() if shapes
                                            else (), strict=True)):
        body.add_geom(name=f"{part.name}_visual_{k}", **_shape_geom(shape),
                      rgba=rgba if colour is None else float32(colour), **visual_only)
    meshes = dict(layout.collisions[part.name])
    for k, piece in enumerate(part.collision):
        name = f"{part.name}_collision_{k}"
        if piece.primitive is not None:
            body.add_geom(name=name, **_shape_geom(piece.primitive), group=COLLISION_GROUP,
                          rgba=rgba)
        else:
            body.add_geom(name=name, type=mesh_geom, meshname=_stem(meshes[k].relpath),
                          group=COLLISION_GROUP, rgba=rgba, **_placed(meshes[k].pose))


def _placed(pose: np.ndarray | None) -> dict:
    """A mesh geom's pos and quat in its body, for a mesh file placed at ``pose``."""
    if pose is None:
        return {}
    return dict(pos=snap_position(pose[:3, 3]),
                quat=snap_unit(tf.matrix_to_quat(pose[:3, :3]), sign_free=True))


def _shape_geom(shape) -> dict:
    """A primitive geom's type, size and pose (in its body, the part frame)."""
    kind, size = mjcf_geom(shape)
    return dict(type=kind, size=size, pos=[x + 0.0 for x in shape.pose[:3, 3]],
                quat=snap_unit(tf.matrix_to_quat(shape.pose[:3, :3]), sign_free=True))


def _placed_joints(chain: list[Joint]) -> tuple[np.ndarray, list[tuple[Joint, np.ndarray,
                                                                         np.ndarray]]]:
    """The body's pose with every hinge and slide of ``chain`` at its state (the joint's
    ``ref``, where MuJoCo starts it), and each joint's anchor and axis in that body frame.

    MuJoCo moves a body from its written pose by each joint in turn, by ``qpos - ref``, about
    the anchor and axis as written. With G_k(q) the k-th joint's motion about its anchor in
    the body at q = 0 (:func:`.structure.anchors`), the model's pose is G_1(q_1) ... G_n(q_n)
    = P G'_1(q_1 - r_1) ... G'_n(q_n - r_n) with P = G_1(r_1) ... G_n(r_n) and G'_k the k-th
    motion carried by H_k = (G_{k+1}(r_{k+1}) ... G_n(r_n))^-1: its anchor H_k p_k, its axis
    R(H_k) a_k."""
    base, points = anchors(chain)
    steps = [tf.make(translation=p) @ j.motion(j.state if not j.type.multi_dof else 0.0)
             @ tf.make(translation=-p) for j, p in zip(chain, points, strict=True)]
    pose = base
    for step in steps:
        pose = pose @ step
    placed, after = [], np.eye(4)
    for joint, point, step in reversed(list(zip(chain, points, steps, strict=True))):
        h = np.linalg.inv(after)
        placed.append((joint, h[:3, :3] @ point + h[:3, 3], h[:3, :3] @ joint.axis))
        after = step @ after
    return pose, placed[::-1]


def _add_joint(body, joint: Joint, anchor: np.ndarray, axis: np.ndarray) -> None:
    import mujoco

    d = joint.dynamics
    options = dict(name=joint.name, damping=d.damping, frictionloss=d.friction,
                   stiffness=d.stiffness, armature=d.armature)
    if np.any(anchor):
        options["pos"] = [x + 0.0 for x in anchor]
    if joint.type.multi_dof:
        kind = mujoco.mjtJoint.mjJNT_BALL if joint.type is JointType.BALL else \
            mujoco.mjtJoint.mjJNT_FREE
        if joint.cone_limit is not None:  # a ball's range: [0, the largest rotation]
            options.update(limited=mujoco.mjtLimited.mjLIMITED_TRUE,
                           range=[0.0, joint.cone_limit])
        body.add_joint(type=kind, **options)
        return
    kind = mujoco.mjtJoint.mjJNT_HINGE if joint.type.angular else mujoco.mjtJoint.mjJNT_SLIDE
    options.update(type=kind, axis=snap_unit(axis), springref=d.spring_ref, ref=joint.state)
    limits = joint.limits
    if limits is None:
        options["limited"] = mujoco.mjtLimited.mjLIMITED_FALSE
    else:
        options["limited"] = mujoco.mjtLimited.mjLIMITED_TRUE
        options["range"] = [limits.lower, limits.upper]
    # the effort limit, with a range or without: the force MuJoCo lets actuators apply at the
    # joint (actuatorfrcrange)
    effort = joint.effort_limit
    if effort is not None and effort > 0:  # 0 is kept in <custom>
        options["actfrclimited"] = mujoco.mjtLimited.mjLIMITED_TRUE
        options["actfrcrange"] = [-effort, effort]
    body.add_joint(**options)


def _add_custom(spec, obj: ArticulatedObject, parts: list[Part], joints: list[Joint]) -> None:
    for joint in joints:
        if joint.type is JointType.FIXED:  # a jointless body has no joint name to carry
            spec.add_text(name=custom_name(joint.child, "parent_joint"), data=joint.name)
        if joint.velocity_limit is not None:  # MuJoCo has no velocity limit
            spec.add_numeric(name=custom_name(joint.name, "velocity"),
                             data=[joint.velocity_limit])
        if joint.effort_limit is not None and not joint.effort_limit > 0:
            spec.add_numeric(name=custom_name(joint.name, "effort"), data=[joint.effort_limit])
        if joint.drive is not None and joint.drive.target != 0:  # MuJoCo's ctrl starts at 0
            spec.add_numeric(name=custom_name(joint.name, "drive_target"),
                             data=[joint.drive.target])
    for part in parts:
        # no geom to carry its colour, or geoms of several colours none of which is the
        # part's own (a mesh file's colours: the part's is their mean)
        if (part.visual is None and not part.collision) or part.color_not_first_run:
            spec.add_numeric(name=custom_name(part.name, "color"), data=list(part.color))
    root = parts[0]
    if root_is_world(obj):
        spec.add_text(name=custom_name(WORLD, "part"), data="root")
        if root.name != WORLD:
            spec.add_text(name=custom_name(WORLD, "name"), data=root.name)
        if root.inertial is not None:
            i = root.inertial
            spec.add_numeric(name=custom_name(WORLD, "inertial"),
                             data=[i.mass, *i.com, *full_inertia(i.inertia)])
    if obj.metadata:
        text = metadata_json(obj, sort_keys=True, separators=(",", ":"))
        # MuJoCo writes text as CDATA (turned into an attribute by to_xml), which
        # "]]>" would end; \u003e is the same JSON.
        spec.add_text(name=METADATA, data=text.replace(">", "\\u003e"))


def _element_owner(obj: ArticulatedObject, name: str) -> str:
    """Which part or joint a MuJoCo element name belongs to (body, joint, geom, mesh)."""
    owners, layout = [], MeshLayout(obj)
    for part in obj.parts:
        shapes = len(part.visual.primitives) if part.visual is not None else 0
        names = {part.name} | {g.name for g in layout.visuals[part.name]} | {
            visual_element_name(part.name, 0)} | {
            f"{part.name}_collision_{k}" for k in range(len(part.collision))} | {
            f"{part.name}_visual_{k}" for k in range(shapes)}
        if name in names:
            owners.append(f"part {part.name!r}" + ("" if name == part.name else f" ({name!r})"))
    owners += [f"joint {j.name!r}" for j in obj.joints if j.name == name]
    return " or ".join(owners) if owners else repr(name)
