"""Textures through every format that holds them: a part with texture coordinates and an
image (made here) keeps both through object.json, URDF (OBJ + MTL), glTF, USD and MJCF and
back: the same pixels, UVs within 1e-6; the validators stay at zero errors. Where a format or
a file cannot hold a texture, a warning says so."""

from __future__ import annotations

import io
import warnings

import numpy as np
import pytest

from real2code_export.formats import export, load
from real2code_export.model import (
    PBR_MAPS,
    ArticulatedObject,
    Inertial,
    Joint,
    JointType,
    Limits,
    Mesh,
    Part,
    Texture,
    differences,
)

UV_TOL = 1e-6


def png(width: int = 16, height: int = 8, seed: int = 0) -> bytes:
    from PIL import Image

    pixels = np.random.default_rng(seed).integers(0, 256, (height, width, 3), dtype=np.uint8)
    buffer = io.BytesIO()
    Image.fromarray(pixels).save(buffer, format="PNG")
    return buffer.getvalue()


def uv_box(size=(0.4, 0.02, 0.6)) -> Mesh:
    """A box with its own square of the image on each face (24 vertices: a corner has three
    texture coordinates, so three vertices)."""
    half = np.asarray(size) / 2
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * half
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    vertices, uv, faces = [], [], []
    for k, quad in enumerate(quads):
        base = len(vertices)
        vertices += [corners[i] for i in quad]
        u0 = k / 6
        uv += [(u0, 0.1), (u0 + 1 / 6, 0.1), (u0 + 1 / 6, 0.9), (u0, 0.9)]
        faces += [(base, base + 1, base + 2), (base, base + 2, base + 3)]
    return Mesh(np.array(vertices), np.array(faces), np.array(uv))


def textured_cabinet() -> ArticulatedObject:
    body = Part("body", Mesh.concatenate([uv_box((0.5, 0.5, 0.7))]).transformed(np.eye(4)),
                inertial=Inertial(5.0, np.zeros(3), np.eye(3) * 0.1), color=(0.6, 0.5, 0.4, 1.0))
    body = Part("body", Mesh(body.visual.vertices, body.visual.faces), inertial=body.inertial,
                color=body.color)  # an untextured part beside a textured one
    door = Part("door", uv_box(), inertial=Inertial(1.0, np.zeros(3), np.eye(3) * 0.01),
                color=(1.0, 1.0, 1.0, 1.0), texture=Texture(png(), "image/png", "wood"))
    origin = np.eye(4)
    origin[:3, 3] = (0.3, -0.2, 0.0)
    hinge = Joint("door_hinge", JointType.REVOLUTE, "body", "door", origin, [0.0, 0.0, 1.0],
                  Limits(0.0, 1.5, 10.0, 2.0), state=0.3)
    return ArticulatedObject("textured_cabinet", [body, door], [hinge])


def test_the_model_refuses_a_texture_without_uvs():
    from real2code_export.errors import ModelError

    with pytest.raises(ModelError, match="texture coordinates"):
        Part("p", Mesh(np.eye(3), [[0, 1, 2]]), texture=Texture(png(), "image/png", "t"))
    with pytest.raises(ModelError, match="PNG or JPEG"):
        Texture(b"GIF89a", "image/gif", "t")


@pytest.mark.parametrize("fmt", ["json", "urdf", "gltf", "usd", "mjcf"])
def test_texture_round_trip(tmp_path, fmt):
    obj = textured_cabinet()
    written = export(obj, tmp_path, [fmt])
    back = load(written[fmt])
    door = back.part("door")
    assert door.texture is not None, fmt
    assert not differences(obj, back, 1e-6) or _only_mesh_precision(obj, back, fmt)
    assert np.abs(door.visual.uv - obj.part("door").visual.uv).max() <= UV_TOL
    from PIL import Image

    same = [np.asarray(Image.open(io.BytesIO(t.image)).convert("RGBA"))
            for t in (obj.part("door").texture, door.texture)]
    assert np.array_equal(*same)  # pixel-equal
    assert back.part("body").texture is None


def _only_mesh_precision(a, b, fmt) -> bool:
    """float32 formats (glTF, USD) differ in the vertices' last digits only."""
    return fmt in ("gltf", "usd") and not differences(a, b, 1e-5)


def test_textured_exports_pass_the_validators_and_the_check(tmp_path):
    from real2code_export.check import check_files
    from real2code_export.validators import validate_files

    written = export(textured_cabinet(), tmp_path, ["json", "urdf", "mjcf", "usd", "gltf"])
    for result in validate_files([written["gltf"], written["usd"]]):
        assert result.errors == 0, result.messages
    report = check_files([str(p) for p in written.values()], n_configurations=5)
    assert report.ok, report


def test_what_cannot_be_kept_is_warned_about(tmp_path):
    """An OBJ naming an image that is not there, and a TGA converted to PNG."""
    from PIL import Image

    from real2code_export.errors import Real2CodeWarning
    from real2code_export.meshfiles import obj_bytes, read_mesh_file

    mesh = uv_box()
    (tmp_path / "a.obj").write_bytes(obj_bytes(mesh, material="a"))
    (tmp_path / "a.mtl").write_text("newmtl a\nKd 1 1 1\nmap_Kd missing.png\n")
    with pytest.warns(Real2CodeWarning, match="missing.png not found"):
        assert read_mesh_file(tmp_path / "a.obj").texture is None
    Image.new("RGB", (4, 4), (200, 10, 10)).save(tmp_path / "wood.tga")
    (tmp_path / "a.mtl").write_text("newmtl a\nKd 1 1 1\nmap_Kd wood.tga\n")
    with pytest.warns(Real2CodeWarning, match="converted to PNG"):
        texture = read_mesh_file(tmp_path / "a.obj").texture
    assert texture.mime == "image/png" and texture.name == "wood"
    assert read_mesh_file(tmp_path / "a.obj").mesh.uv is not None


def test_obj_corners_with_two_coordinates_become_two_vertices(tmp_path):
    """OBJ indexes positions and texture coordinates apart; the model keeps one UV per
    vertex, so a corner shared by faces with different coordinates is split."""
    from real2code_export.meshfiles import read_mesh

    (tmp_path / "q.obj").write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
                                    "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvt 0.5 0.5\n"
                                    "f 1/1 2/2 3/3\nf 1/5 3/3 4/4\n")
    mesh = read_mesh(tmp_path / "q.obj")
    assert len(mesh.vertices) == 5 and len(mesh.faces) == 2
    corner_uv = {tuple(mesh.vertices[i][:2]) + tuple(mesh.uv[i]) for i in mesh.faces.ravel()}
    assert (0.0, 0.0, 0.0, 0.0) in corner_uv and (0.0, 0.0, 0.5, 0.5) in corner_uv


def test_a_khr_physics_file_without_our_extras_keeps_its_texture(tmp_path):
    """Other tools' glTF (no real2code extras) is read through KHR_physics_rigid_bodies: the
    textured door keeps its image and coordinates."""
    import pygltflib
    from PIL import Image

    from real2code_export.errors import Real2CodeWarning

    obj = textured_cabinet()
    written = export(obj, tmp_path, ["gltf"])
    doc = pygltflib.GLTF2.load(str(written["gltf"]))
    for item in [*doc.nodes, *doc.animations, *(p for m in doc.meshes for p in m.primitives)]:
        item.extras = {}
    foreign = tmp_path / "foreign.glb"
    doc.save(str(foreign))
    with pytest.warns(Real2CodeWarning, match="KHR_physics_rigid_bodies"):
        back = load(foreign)
    door = next(p for p in back.parts if p.texture is not None)
    same = [np.asarray(Image.open(io.BytesIO(t.image)).convert("RGBA"))
            for t in (obj.part("door").texture, door.texture)]
    assert np.array_equal(*same)
    assert np.abs(door.visual.uv - obj.part("door").visual.uv).max() <= UV_TOL
    assert [p.name for p in back.parts if p.texture is not None] == [door.name]


def pbr_cabinet(packed: bool = False) -> ArticulatedObject:
    """The textured cabinet's door with every glTF material map beside its colour image;
    ``packed``: occlusion in the metallic-roughness image's R (glTF's ORM packing)."""
    obj = textured_cabinet()
    door = obj.part("door")
    maps = {role: Texture(png(8, 8, seed=k + 1), "image/png", role)
            for k, role in enumerate(PBR_MAPS)}
    if packed:
        maps["occlusion"] = maps["metallic_roughness"]
    obj.parts[obj.parts.index(door)] = Part(door.name, door.visual, door.collision,
                                            door.inertial, door.color, door.texture, maps)
    return obj


@pytest.mark.parametrize("fmt", ["json", "gltf", "usd", "mjcf"])
def test_material_maps_round_trip(tmp_path, fmt):
    """Metallic-roughness, normal, occlusion and emissive maps come back pixel-equal in the
    formats whose materials hold them (MJCF: MuJoCo's ORM packs occlusion with them)."""
    obj = pbr_cabinet(packed=fmt == "mjcf")
    back = load(export(obj, tmp_path, [fmt])[fmt])
    assert sorted(back.part("door").maps) == sorted(PBR_MAPS), fmt
    assert not differences(obj, back, 1e-6) or _only_mesh_precision(obj, back, fmt)
    assert back.part("body").maps == {}


def test_material_maps_pass_the_validators_and_are_wired_as_their_format_says(tmp_path):
    import pygltflib
    from pxr import Usd, UsdShade

    from real2code_export.validators import validate_files

    written = export(pbr_cabinet(), tmp_path, ["gltf", "usd"])
    for result in validate_files([written["gltf"], written["usd"]]):
        assert result.errors == 0, result.messages
    doc = pygltflib.GLTF2.load(str(written["gltf"]))
    door = next(m for m in doc.materials if m.name == "door")
    pbr = door.pbrMetallicRoughness
    assert (pbr.metallicFactor, pbr.roughnessFactor) == (1.0, 1.0)  # the map gives the values
    assert None not in (pbr.metallicRoughnessTexture, door.normalTexture,
                        door.occlusionTexture, door.emissiveTexture)
    stage = Usd.Stage.Open(str(written["usd"]))
    surface = UsdShade.Shader(next(p for p in stage.Traverse() if p.GetName() == "PreviewSurface"
                                   and "door" in str(p.GetPath())))
    wired = {name: surface.GetInput(name).GetConnectedSources()[0][0].sourceName
             for name in ("diffuseColor", "roughness", "metallic", "normal", "occlusion",
                          "emissiveColor")}
    assert wired == {"diffuseColor": "rgb", "roughness": "g", "metallic": "b",
                     "normal": "rgb", "occlusion": "r", "emissiveColor": "rgb"}


def test_maps_a_format_cannot_use_are_warned_about(tmp_path):
    from real2code_export.errors import Real2CodeWarning

    with pytest.warns(Real2CodeWarning, match="metallic_roughness, normal, occlusion"):
        back = load(export(pbr_cabinet(), tmp_path / "urdf", ["urdf"])["urdf"])
    assert back.part("door").texture is not None and back.part("door").maps == {}
    with pytest.warns(Real2CodeWarning, match="metallic_roughness map is not used"):
        back = load(export(pbr_cabinet(), tmp_path / "mjcf", ["mjcf"])["mjcf"])
    assert sorted(back.part("door").maps) == ["emissive", "normal", "occlusion"]


def test_an_obj_s_other_material_maps_are_warned_about(tmp_path):
    from real2code_export.errors import Real2CodeWarning
    from real2code_export.meshfiles import obj_bytes, read_mesh_file

    (tmp_path / "a.obj").write_bytes(obj_bytes(uv_box(), material="a"))
    (tmp_path / "wood.png").write_bytes(png())
    (tmp_path / "a.mtl").write_text("newmtl a\nKd 1 1 1\nmap_Kd wood.png\nnorm bumps.png\n")
    with pytest.warns(Real2CodeWarning, match=r"normal \(bumps.png\) are not kept"):
        assert read_mesh_file(tmp_path / "a.obj").texture is not None


def test_a_jpeg_texture_reaches_mujoco_as_png_with_its_pixels(tmp_path):
    """MuJoCo decodes no JPEG: the MJCF export refers to a PNG of the JPEG's pixels beside the
    shared JPEG (which the other formats keep byte for byte); read back, the pixels are equal."""
    from PIL import Image

    buffer = io.BytesIO()
    Image.open(io.BytesIO(png())).convert("RGB").save(buffer, format="JPEG")
    obj = textured_cabinet()
    door = obj.part("door")
    door.texture = Texture(buffer.getvalue(), "image/jpeg", "wood")
    written = export(obj, tmp_path)
    from real2code_export.meshfiles import texture_relpath

    relpath = texture_relpath(door)  # meshes/wood_<digest>.jpg
    assert relpath.startswith("meshes/wood_") and relpath.endswith(".jpg")
    assert (tmp_path / relpath).read_bytes() == buffer.getvalue()
    assert f'file="{relpath[len("meshes/"):-4]}.png"' in written["mjcf"].read_text()
    for fmt, path in written.items():
        assert not [d for d in differences(obj, load(path), 1e-6) if "texture" in d], fmt


def test_a_urdf_material_s_texture_is_placed_by_the_mesh_s_coordinates(tmp_path):
    """<material><texture filename> (inline, or by the robot's material of that name) on a
    mesh with texture coordinates: its image, as rviz draws it; on a shape, or where the
    image is not there: warned, the colour kept."""
    from real2code_export.errors import Real2CodeWarning
    from real2code_export.meshfiles import obj_bytes

    (tmp_path / "wood.png").write_bytes(png(8, 4, seed=3))
    (tmp_path / "door.obj").write_bytes(obj_bytes(uv_box()))  # coordinates, no MTL
    link = """<link name="{name}"><inertial><mass value="1"/><inertia ixx="0.1" iyy="0.1"
      izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial><visual><geometry>{shape}</geometry>
      {material}</visual></link>"""
    mesh = '<mesh filename="door.obj"/>'
    links = [("inline", mesh, '<material name="w"><texture filename="wood.png"/></material>'),
             ("named", mesh, '<material name="oak"/>'),
             ("shape", '<box size="1 1 1"/>', '<material name="oak"/>'),
             ("missing", mesh, '<material name="m"><texture filename="gone.png"/>'
                               '<color rgba="1 0 0 1"/></material>')]
    joints = "".join(f'<joint name="j{k}" type="fixed"><parent link="inline"/>'
                     f'<child link="{n}"/></joint>' for k, (n, _, _) in enumerate(links[1:]))
    (tmp_path / "r.urdf").write_text(
        '<robot name="r"><material name="oak"><color rgba="1 1 1 1"/>'
        '<texture filename="wood.png"/></material>'
        + "".join(link.format(name=n, shape=s, material=m) for n, s, m in links)
        + joints + "</robot>")
    with pytest.warns(Real2CodeWarning) as said:
        obj = load(tmp_path / "r.urdf")
    messages = " | ".join(str(w.message) for w in said)
    wood = (tmp_path / "wood.png").read_bytes()
    assert obj.part("inline").texture.image == wood and obj.part("named").texture.image == wood
    assert obj.part("shape").texture is None and "no texture coordinates" in messages
    assert obj.part("missing").texture is None and "image not found" in messages
    assert obj.part("missing").color == (1.0, 0.0, 0.0, 1.0)


def test_an_image_several_parts_show_is_one_gltf_image(tmp_path):
    import pygltflib

    obj = textured_cabinet()
    door = obj.part("door")
    obj.part("body").visual = uv_box((0.5, 0.5, 0.7))
    obj.part("body").texture = Texture(door.texture.image, door.texture.mime, door.texture.name)
    written = export(obj, tmp_path, ["gltf"])
    gltf = pygltflib.GLTF2().load(str(written["gltf"]))
    assert len(gltf.images) == 1 and len(gltf.textures) == 1
    others = export(obj, tmp_path / "files", ["urdf", "mjcf"])  # one file, one MuJoCo asset
    assert len(list((tmp_path / "files" / "meshes").glob("wood_*.png"))) == 1
    assert others["mjcf"].read_text().count("<texture ") == 1
    back = load(written["gltf"])
    assert back.part("body").texture.image == back.part("door").texture.image == door.texture.image


def test_a_textured_part_s_colour_tints_its_image_in_usd_as_in_gltf(tmp_path):
    """The part's colour multiplies its image in glTF (baseColorFactor), MTL (Kd) and MuJoCo
    (material rgba); USD's preview surface draws a connected diffuseColor from the image
    alone, so the tint is the UsdUVTexture's scale. Read back, an image's colour is that
    scale (white where none is authored), never the diffuseColor value the image hides."""
    from pxr import Usd, UsdShade

    obj = textured_cabinet()
    obj.part("door").color = (0.5, 0.25, 1.0, 1.0)
    written = export(obj, tmp_path, ["usd"])
    stage = Usd.Stage.Open(str(written["usd"]))
    scales = [UsdShade.Shader(p).GetInput("scale").Get() for p in stage.Traverse()
              if p.GetName() == "Image"]
    assert [tuple(s) for s in scales] == [(0.5, 0.25, 1.0, 1.0)]
    assert load(written["usd"]).part("door").color == (0.5, 0.25, 1.0, 1.0)
    for p in stage.Traverse():  # as other tools write it: no scale, a value behind the image
        if p.GetName() == "Image":
            p.RemoveProperty("inputs:scale")
    stage.GetRootLayer().Save()
    assert load(written["usd"]).part("door").color == (1.0, 1.0, 1.0, 1.0)


def test_a_usd_material_s_interface_inputs_give_its_image_and_colour(tmp_path):
    """The NVIDIA converters (Isaac Sim's importers) connect a shader's inputs to the
    Material's own inputs, where the values are: the image's file and a plain colour read
    through those connections (the image was dropped in silence)."""
    from pxr import Gf, Sdf, Usd, UsdGeom, UsdPhysics, UsdShade, Vt

    (tmp_path / "wood.png").write_bytes(png(8, 4, seed=5))
    stage = Usd.Stage.CreateNew(str(tmp_path / "m.usda"))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    stage.SetDefaultPrim(UsdGeom.Xform.Define(stage, "/r").GetPrim())
    for k, name in enumerate(("textured", "plain")):
        body = UsdGeom.Xform.Define(stage, f"/r/{name}")
        UsdPhysics.RigidBodyAPI.Apply(body.GetPrim())
        UsdPhysics.MassAPI.Apply(body.GetPrim()).CreateMassAttr(1.0)
        mesh = UsdGeom.Mesh.Define(stage, f"/r/{name}/mesh")
        mesh.CreatePointsAttr([Gf.Vec3f(0, 0, 2 * k), Gf.Vec3f(1, 0, 2 * k),
                               Gf.Vec3f(0, 1, 2 * k), Gf.Vec3f(0, 0, 2 * k + 1)])
        mesh.CreateFaceVertexCountsAttr([3] * 4)
        mesh.CreateFaceVertexIndicesAttr([0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3])
        UsdGeom.PrimvarsAPI(mesh).CreatePrimvar(
            "st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex).Set(
            Vt.Vec2fArray([(0.1, 0.1), (0.9, 0.1), (0.1, 0.9), (0.9, 0.9)]))
        material = UsdShade.Material.Define(stage, f"/r/Looks/{name}")
        surface = UsdShade.Shader.Define(stage, f"/r/Looks/{name}/Surface")
        surface.CreateIdAttr("UsdPreviewSurface")
        material.CreateSurfaceOutput().ConnectToSource(surface.ConnectableAPI(), "surface")
        diffuse = surface.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f)
        if name == "textured":
            file = material.CreateInput("ColorTexture", Sdf.ValueTypeNames.Asset)
            file.Set("./wood.png")
            image = UsdShade.Shader.Define(stage, f"/r/Looks/{name}/ColorTexture")
            image.CreateIdAttr("UsdUVTexture")
            image.CreateInput("file", Sdf.ValueTypeNames.Asset).ConnectToSource(file)
            diffuse.ConnectToSource(image.ConnectableAPI(), "rgb")
        else:
            colour = material.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f)
            colour.Set(Gf.Vec3f(0.25, 0.5, 0.75))
            diffuse.ConnectToSource(colour)
        UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(material)
    stage.Save()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        obj = load(tmp_path / "m.usda")
    assert obj.part("textured").texture.image == (tmp_path / "wood.png").read_bytes()
    assert obj.part("plain").color == pytest.approx((0.25, 0.5, 0.75, 1.0))


def jpeg_cabinet() -> ArticulatedObject:
    from PIL import Image

    buffer = io.BytesIO()
    Image.open(io.BytesIO(png())).convert("RGB").save(buffer, format="JPEG")
    obj = textured_cabinet()
    obj.part("door").texture = Texture(buffer.getvalue(), "image/jpeg", "wood")
    return obj


def test_mujoco_s_png_copy_of_a_jpeg_is_encoded_once(tmp_path, monkeypatch):
    """Exporting the same JPEG again takes its PNG copy from the disk cache: nothing encoded."""
    from PIL import Image

    monkeypatch.setenv("REAL2CODE_CACHE", str(tmp_path / "cache"))
    first = export(jpeg_cabinet(), tmp_path / "first", ["mjcf"])["mjcf"]
    png_copy = next((tmp_path / "first" / "meshes").glob("wood_*.png")).read_bytes()

    def refuse(*args, **kwargs):
        raise AssertionError("an image was encoded")

    obj = jpeg_cabinet()
    monkeypatch.setattr(Image.Image, "save", refuse)
    again = export(obj, tmp_path / "again", ["mjcf"])["mjcf"]
    assert next((tmp_path / "again" / "meshes").glob("wood_*.png")).read_bytes() == png_copy
    assert again.read_text() == first.read_text()


def test_mujoco_writes_the_mjcf_without_decoding_its_images(tmp_path, monkeypatch):
    """The compile before MuJoCo writes the XML is given placeholder images: the XML is the
    same, and the export's PNG (read by MuJoCo when the file is loaded) is checked whole
    instead, a broken one refused naming its part and image."""
    import mujoco

    from real2code_export.errors import ExportError

    monkeypatch.setenv("REAL2CODE_CACHE", "off")
    written = export(textured_cabinet(), tmp_path / "ok", ["mjcf"])["mjcf"]
    model = mujoco.MjModel.from_xml_path(str(written))  # the real image, decoded
    assert model.ntex == 1 and (model.tex_width[0], model.tex_height[0]) == (16, 8)
    obj = textured_cabinet()
    data = obj.part("door").texture.image
    obj.part("door").texture = Texture(data[:-20] + bytes(8) + data[-12:], "image/png", "wood")
    with pytest.raises(ExportError, match=r"part 'door': image 'wood' .*not a PNG MuJoCo"):
        export(obj, tmp_path / "broken", ["mjcf"])
    assert not (tmp_path / "broken").exists()
