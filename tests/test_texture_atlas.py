"""Several images and colours on one part become one image (a texture atlas): every face
draws the same texel it drew before packing, sampled as glTF and OpenGL sample (texel
centres at (i + 0.5) / width, v up); flat colours are sRGB-encoded tiles; a repeating image
is unrolled. Read from Collada meshes with images, OBJs naming several ``map_Kd`` and URDF
links whose visuals bring their own images, and carried through every format."""

from __future__ import annotations

import io
import warnings

import numpy as np
import pytest

from real2code_export.errors import Real2CodeWarning
from real2code_export.model import Mesh, Texture
from real2code_export.texture_atlas import (
    AtlasPiece,
    linear_to_srgb,
    needs_atlas,
    pack,
    srgb_to_linear,
)


def noise_png(width: int, height: int, seed: int) -> tuple[bytes, np.ndarray]:
    from PIL import Image

    pixels = np.random.default_rng(seed).integers(0, 256, (height, width, 4), dtype=np.uint8)
    pixels[..., 3] = 255
    buffer = io.BytesIO()
    Image.fromarray(pixels, "RGBA").save(buffer, format="PNG")
    return buffer.getvalue(), pixels


def texel_centres(width: int, height: int, n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    i, j = rng.integers(0, width, n), rng.integers(0, height, n)  # j: row from the top
    return np.column_stack([(i + 0.5) / width, 1 - (j + 0.5) / height])


def sample(pixels: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """Nearest texel, as glTF samples: u right, v up, texel i spans [i, i + 1) / size."""
    height, width = pixels.shape[:2]
    x = np.clip(np.floor(uv[:, 0] * width), 0, width - 1).astype(int)
    y = np.clip(np.floor((1 - uv[:, 1]) * height), 0, height - 1).astype(int)
    return pixels[y, x]


def decoded(texture: Texture) -> np.ndarray:
    from PIL import Image

    return np.asarray(Image.open(io.BytesIO(texture.image)).convert("RGBA"))


def triangles(uv: np.ndarray, seed: int) -> Mesh:
    return Mesh(np.random.default_rng(seed).random((len(uv), 3)),
                np.arange(len(uv)).reshape(-1, 3), uv)


def test_every_face_draws_the_texel_it_drew():
    a, a_px = noise_png(16, 8, 0)
    b, b_px = noise_png(5, 7, 1)
    uv_a, uv_b = texel_centres(16, 8, 30, 2), texel_centres(5, 7, 30, 3)
    flat = Mesh(np.eye(3), [[0, 1, 2]])
    tint = (0.5, 1.0, 0.25, 1.0)
    pieces = [AtlasPiece(triangles(uv_a, 4), Texture(a, "image/png", "a"), (1, 1, 1, 1)),
              AtlasPiece(flat, None, (0.5, 0.2, 0.1, 1.0)),
              AtlasPiece(triangles(uv_b, 5), Texture(b, "image/png", "b"), tint)]
    assert needs_atlas(pieces)
    atlas = pack(pieces)
    assert atlas.texture.mime == "image/png" and not atlas.notes
    assert len(atlas.mesh.vertices) == 63 and len(atlas.mesh.faces) == 21
    drawn = sample(decoded(atlas.texture), atlas.mesh.uv)
    assert np.array_equal(drawn[:30], sample(a_px, uv_a))
    flat_texel = np.round(linear_to_srgb(np.array([0.5, 0.2, 0.1])) * 255)
    assert np.array_equal(drawn[30:33, :3], np.tile(flat_texel, (3, 1)))
    tinted = linear_to_srgb(srgb_to_linear(sample(b_px, uv_b)[:, :3] / 255) * tint[:3]) * 255
    assert np.abs(drawn[33:, :3] - tinted).max() <= 0.5 + 1e-9


def test_a_filtering_sampler_at_a_tile_s_edge_reads_the_tile():
    """Each tile's edge pixels repeat around it: a coordinate on the tile's border (u = 0)
    half a texel out still reads the tile's own colour."""
    a, a_px = noise_png(4, 4, 0)
    edge = np.array([[0.0, 0.5], [1.0, 0.5], [0.5, 0.0]])
    pieces = [AtlasPiece(triangles(edge, 0), Texture(a, "image/png", "a"), (1, 1, 1, 1)),
              AtlasPiece(Mesh(np.eye(3), [[0, 1, 2]]), None, (0.0, 0.0, 1.0, 1.0))]
    atlas = pack(pieces)
    pixels = decoded(atlas.texture)
    height, width = pixels.shape[:2]
    half_out = atlas.mesh.uv[:3] + np.array([[-0.5 / width, 0], [0.5 / width, 0],
                                            [0, -0.5 / height]])
    assert np.array_equal(sample(pixels, half_out), sample(a_px, np.clip(edge, 0, 0.999)))


def test_a_repeating_image_is_unrolled():
    a, a_px = noise_png(5, 7, 1)
    uv = texel_centres(5, 7, 30, 3) * 3 - 1  # three copies across, from -1
    pieces = [AtlasPiece(triangles(uv, 0), Texture(a, "image/png", "a"), (1, 1, 1, 1)),
              AtlasPiece(Mesh(np.eye(3), [[0, 1, 2]]), None, (1.0, 0.0, 0.0, 1.0))]
    atlas = pack(pieces)
    assert np.array_equal(sample(decoded(atlas.texture), atlas.mesh.uv[:30]),
                          sample(a_px, np.mod(uv, 1.0)))


def test_what_needs_an_atlas():
    a, _ = noise_png(4, 4, 0)
    b, _ = noise_png(4, 4, 1)
    uv = texel_centres(4, 4, 3, 0)
    image = AtlasPiece(triangles(uv, 0), Texture(a, "image/png", "a"), (1, 1, 1, 1))
    same = AtlasPiece(triangles(uv, 1), Texture(a, "image/png", "a2"), (1, 1, 1, 1))
    other = AtlasPiece(triangles(uv, 2), Texture(b, "image/png", "b"), (1, 1, 1, 1))
    flat = AtlasPiece(Mesh(np.eye(3), [[0, 1, 2]]), None, (1, 0, 0, 1))
    assert not needs_atlas([image, same])  # one image, one tint
    assert needs_atlas([image, other]) and needs_atlas([image, flat])
    assert not needs_atlas([flat])


COLLADA = """<?xml version="1.0" encoding="utf-8"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
  <asset><unit name="centimeter" meter="0.01"/><up_axis>Z_UP</up_axis></asset>
  <library_images><image id="img"><init_from>{image}</init_from></image></library_images>
  <library_effects>
    <effect id="wood-fx"><profile_COMMON>
      <newparam sid="s"><surface type="2D"><init_from>img</init_from></surface></newparam>
      <newparam sid="t"><sampler2D><source>s</source></sampler2D></newparam>
      <technique sid="c"><lambert><diffuse><texture texture="t" texcoord="UVMap"/></diffuse>
      </lambert></technique></profile_COMMON></effect>
    <effect id="red-fx"><profile_COMMON><technique sid="c"><lambert>
      <diffuse><color>1 0 0 1</color></diffuse></lambert></technique></profile_COMMON></effect>
  </library_effects>
  <library_materials>
    <material id="wood"><instance_effect url="#wood-fx"/></material>
    <material id="red"><instance_effect url="#red-fx"/></material>
  </library_materials>
  <library_geometries><geometry id="g"><mesh>
    <source id="p"><float_array id="pa" count="12">0 0 0 100 0 0 0 100 0 100 100 0</float_array>
      <technique_common><accessor source="#pa" count="4" stride="3"><param name="X" type="float"/>
      <param name="Y" type="float"/><param name="Z" type="float"/></accessor></technique_common>
    </source>
    <source id="t"><float_array id="ta" count="8">{uv}</float_array>
      <technique_common><accessor source="#ta" count="4" stride="2"><param name="S" type="float"/>
      <param name="T" type="float"/></accessor></technique_common></source>
    <vertices id="v"><input semantic="POSITION" source="#p"/></vertices>
    <triangles material="wood-sym" count="2"><input semantic="VERTEX" source="#v" offset="0"/>
      <input semantic="TEXCOORD" source="#t" offset="1" set="0"/>
      <p>0 0 1 1 2 2 1 1 3 3 2 2</p></triangles>
    {red}
  </mesh></geometry></library_geometries>
  <library_visual_scenes><visual_scene id="s"><node id="n">
    <instance_geometry url="#g"><bind_material><technique_common>
      <instance_material symbol="wood-sym" target="#wood">
        <bind_vertex_input semantic="UVMap" input_semantic="TEXCOORD" input_set="0"/>
      </instance_material>
      <instance_material symbol="red-sym" target="#red"/>
    </technique_common></bind_material></instance_geometry>
  </node></visual_scene></library_visual_scenes>
  <scene><instance_visual_scene url="#s"/></scene>
</COLLADA>
"""
RED_TRIANGLE = """<triangles material="red-sym" count="1"><input semantic="VERTEX" source="#v"
      offset="0"/><input semantic="TEXCOORD" source="#t" offset="1" set="0"/>
      <p>0 0 1 0 3 0</p></triangles>"""


def collada_file(tmp_path, uv: np.ndarray, red: bool, image: str = "wood.png") -> tuple:
    data, pixels = noise_png(8, 8, 7)
    (tmp_path / "wood.png").write_bytes(data)
    path = tmp_path / "m.dae"
    path.write_text(COLLADA.format(image=image, uv=" ".join(f"{x:.6f}" for x in uv.ravel()),
                                   red=RED_TRIANGLE if red else ""))
    return path, data, pixels


def test_a_collada_mesh_drawn_from_one_image_keeps_it_as_it_is(tmp_path):
    from real2code_export.meshfiles import read_mesh_file

    uv = texel_centres(8, 8, 4, 1)
    path, data, pixels = collada_file(tmp_path, uv, red=False)
    with warnings.catch_warnings():
        warnings.simplefilter("error", Real2CodeWarning)
        read = read_mesh_file(path)
    assert read.texture is not None and read.texture.image == data  # the file's bytes
    assert read.color == (1.0, 1.0, 1.0, 1.0)
    assert np.allclose(read.mesh.vertices.max(axis=0), [1.0, 1.0, 0.0])  # the unit applied
    # each corner keeps its coordinate: the corner at (1, 1, 0) is the fourth
    corner = np.flatnonzero(np.all(np.isclose(read.mesh.vertices, [1, 1, 0]), axis=1))[0]
    assert np.allclose(read.mesh.uv[corner], uv[3])


def test_a_collada_corner_indexed_coordinate_of_equal_values_is_one_vertex(tmp_path):
    """Exporters give each corner a coordinate index of its own, the values repeated: equal
    values are one vertex (else every triangle stands alone), different values split it."""
    from real2code_export.meshfiles import read_mesh_file

    uv = texel_centres(8, 8, 4, 1)
    path, _, _ = collada_file(tmp_path, uv, red=False)
    per_corner = uv[[0, 1, 2, 1, 3, 2]]  # six corners, six indices, four values
    text = path.read_text().replace('count="8">', 'count="12">').replace(
        " ".join(f"{x:.6f}" for x in uv.ravel()),
        " ".join(f"{x:.6f}" for x in per_corner.ravel())).replace(
        'source="#ta" count="4"', 'source="#ta" count="6"').replace(
        "<p>0 0 1 1 2 2 1 1 3 3 2 2</p>", "<p>0 0 1 1 2 2 1 3 3 4 2 5</p>")
    path.write_text(text)
    read = read_mesh_file(path)
    assert len(read.mesh.vertices) == 4 and len(read.mesh.faces) == 2
    corner = np.flatnonzero(np.all(np.isclose(read.mesh.vertices, [1, 1, 0]), axis=1))[0]
    assert np.allclose(read.mesh.uv[corner], uv[3])


def one_link(tmp_path, mesh_file: str, material: str = ""):
    """The part of a URDF of one link whose one visual is ``mesh_file``."""
    from real2code_export.formats import load

    (tmp_path / "one.urdf").write_text(
        '<robot name="r"><link name="l"><inertial><mass value="1"/><inertia ixx="0.1" '
        'iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial><visual><geometry><mesh '
        f'filename="{mesh_file}"/></geometry>{material}</visual></link></robot>')
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", "no <collision>", Real2CodeWarning)
        return load(tmp_path / "one.urdf").part("l")


def test_a_collada_mesh_of_an_image_and_a_colour_becomes_one_image(tmp_path):
    from real2code_export.meshfiles import read_mesh_file

    uv = texel_centres(8, 8, 4, 1)
    path, _, pixels = collada_file(tmp_path, uv, red=True)
    looks = read_mesh_file(path).looks  # the file's: packed by the part that shows it
    assert [(n, t is not None, c) for n, t, c in looks] == [(2, True, (1, 1, 1, 1)),
                                                         (1, False, (1, 0, 0, 1))]
    with pytest.warns(Real2CodeWarning, match="1 image.* and 1 other colour.*packed into one"):
        read = one_link(tmp_path, "m.dae")
    drawn = sample(decoded(read.texture), read.visual.uv)
    faces = read.visual.faces
    assert len(faces) == 3
    assert np.array_equal(drawn[faces[:2].ravel()],  # the wood's corners: their texels
                          sample(pixels, uv[[0, 1, 2, 1, 3, 2]]))
    assert (drawn[faces[2]] == [255, 0, 0, 255]).all()  # the red triangle: red


def test_a_collada_image_that_is_not_there_costs_its_colour_only(tmp_path):
    from real2code_export.meshfiles import read_mesh_file

    path, _, _ = collada_file(tmp_path, texel_centres(8, 8, 4, 1), red=True,
                              image="missing.png")
    with pytest.warns(Real2CodeWarning, match="missing.png not found"):
        read = read_mesh_file(path)
    assert read.texture is None and len(read.mesh.faces) == 3


def two_image_obj(tmp_path) -> tuple:
    """An OBJ of two quads, each drawn from its own image (``usemtl`` a, then b)."""
    a, a_px = noise_png(4, 4, 0)
    b, b_px = noise_png(6, 2, 1)
    (tmp_path / "a.png").write_bytes(a)
    (tmp_path / "b.png").write_bytes(b)
    (tmp_path / "m.mtl").write_text("newmtl a\nKd 1 1 1\nmap_Kd a.png\n"
                                    "newmtl b\nKd 1 1 1\nmap_Kd b.png\n")
    uv_a, uv_b = texel_centres(4, 4, 4, 0), texel_centres(6, 2, 4, 1)
    lines = ["mtllib m.mtl"]
    lines += [f"v {x} {y} {z}" for x, y, z in
              [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (2, 0, 0), (3, 0, 0), (3, 1, 0),
               (2, 1, 0)]]
    lines += [f"vt {u:.6f} {v:.6f}" for u, v in np.vstack([uv_a, uv_b])]
    lines += ["usemtl a", "f 1/1 2/2 3/3 4/4", "usemtl b", "f 5/5 6/6 7/7 8/8"]
    (tmp_path / "m.obj").write_text("\n".join(lines) + "\n")
    return tmp_path / "m.obj", (a_px, uv_a), (b_px, uv_b)


def test_an_obj_of_two_images_becomes_one_image(tmp_path):
    path, (a_px, uv_a), (b_px, uv_b) = two_image_obj(tmp_path)
    with pytest.warns(Real2CodeWarning, match="2 image.*packed into one image"):
        read = one_link(tmp_path, path.name)
    drawn = sample(decoded(read.texture), read.visual.uv)
    left = read.visual.vertices[:, 0] < 1.5
    expected = {tuple(np.round(v, 6)): c for v, c in zip(
        [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)], sample(a_px, uv_a), strict=True)}
    expected |= {tuple(np.round(v, 6)): c for v, c in zip(
        [(2, 0, 0), (3, 0, 0), (3, 1, 0), (2, 1, 0)], sample(b_px, uv_b), strict=True)}
    assert left.sum() == 4
    for vertex, texel in zip(read.visual.vertices, drawn, strict=True):
        assert np.array_equal(texel, expected[tuple(np.round(vertex, 6))])


URDF = """<robot name="r">
  <link name="base"><inertial><mass value="1"/><inertia ixx="0.1" iyy="0.1" izz="0.1"
    ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><geometry><mesh filename="a.obj"/></geometry></visual>
    <visual><origin xyz="0 0 2"/><geometry><mesh filename="b.obj"/></geometry></visual>
    <visual><origin xyz="0 0 4"/><geometry><box size="1 1 1"/></geometry>
      <material name="green"><color rgba="0 1 0 1"/></material></visual>
  </link>
  <link name="lid"><inertial><mass value="1"/><inertia ixx="0.1" iyy="0.1" izz="0.1"
    ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><geometry><box size="1 1 0.1"/></geometry></visual></link>
  <joint name="hinge" type="revolute"><parent link="base"/><child link="lid"/>
    <axis xyz="0 1 0"/><limit lower="0" upper="1" effort="1" velocity="1"/></joint>
</robot>
"""


def test_a_link_of_visuals_with_their_own_images_keeps_them_in_every_format(tmp_path):
    """Two visuals, each an OBJ with its own image, and a green box: one part, one image,
    every face drawing what it drew, through URDF, MJCF, USD and glTF and back."""
    from real2code_export.formats import export, load

    for name, seed, size in (("a", 0, (4, 4)), ("b", 1, (2, 6))):
        data, _ = noise_png(*size, seed)
        (tmp_path / f"{name}.png").write_bytes(data)
        (tmp_path / f"{name}.mtl").write_text(f"newmtl m\nKd 1 1 1\nmap_Kd {name}.png\n")
        (tmp_path / f"{name}.obj").write_text(
            f"mtllib {name}.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0.1 0.1\nvt 0.9 0.1\n"
            "vt 0.9 0.9\nvt 0.1 0.9\nusemtl m\nf 1/1 2/2 3/3 4/4\n")
    (tmp_path / "r.urdf").write_text(URDF)
    with pytest.warns(Real2CodeWarning, match="2 image.* and 1 other colour.*packed into one"):
        obj = load(tmp_path / "r.urdf")
    base = obj.part("base")
    assert base.texture is not None and base.visual.uv is not None
    assert base.color == (1.0, 1.0, 1.0, 1.0)
    before = _face_texels(base)
    written = export(obj, tmp_path / "out", ["urdf", "mjcf", "usd", "gltf"])
    for fmt, path in written.items():
        back = load(path).part("base")
        assert back.texture is not None, fmt
        assert np.array_equal(_face_texels(back), before), fmt


def _face_texels(part) -> np.ndarray:
    """The texel each face's centre of texture coordinates draws, faces ordered by where they
    are (formats may reorder a part's faces)."""
    mesh = part.visual
    centres = mesh.uv[mesh.faces].mean(axis=1)
    where = np.round(mesh.vertices[mesh.faces].mean(axis=1), 4)
    order = np.lexsort(where.T[::-1])
    return sample(decoded(part.texture), centres)[order]


MJCF = """<mujoco model="m">
  <compiler inertiafromgeom="false"/>
  <asset>
    <texture name="ta" type="2d" file="a.png"/><texture name="tb" type="2d" file="b.png"/>
    <material name="ma" texture="ta"/><material name="mb" texture="tb" rgba="1 0.5 0.5 1"/>
    <mesh name="qa" file="a.obj"/><mesh name="qb" file="b.obj"/>
  </asset>
  <worldbody><body name="base">
    <inertial pos="0 0 0" mass="1" diaginertia="0.1 0.1 0.1"/>
    <geom type="mesh" mesh="qa" material="ma"/>
    <geom type="mesh" mesh="qb" material="mb" pos="0 0 2"/>
    <geom type="box" size="0.5 0.5 0.5" pos="0 0 4" rgba="0 1 0 1"/>
  </body></worldbody>
</mujoco>
"""


def tetrahedron_obj(path, uv: np.ndarray) -> None:
    corners = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)]
    path.write_text("".join(f"v {x} {y} {z}\n" for x, y, z in corners)
                    + "".join(f"vt {u:.6f} {v:.6f}\n" for u, v in uv)
                    + "f 1/1 3/3 2/2\nf 1/1 2/2 4/4\nf 1/1 4/4 3/3\nf 2/2 3/3 4/4\n")


def test_an_mjcf_body_of_geoms_with_their_own_images_keeps_them(tmp_path):
    """Two textured mesh geoms (one tinted by its material) and a green box in one body:
    one part, one image, each face drawing what MuJoCo draws (texel x material colour)."""
    from real2code_export.formats import export, load

    for name, seed, size in (("a", 0, (4, 4)), ("b", 1, (6, 2))):
        data, _ = noise_png(*size, seed)
        (tmp_path / f"{name}.png").write_bytes(data)
        tetrahedron_obj(tmp_path / f"{name}.obj", texel_centres(*size, 4, seed))
    (tmp_path / "m.xml").write_text(MJCF)
    obj = load(tmp_path / "m.xml")
    base = obj.part("base")
    assert base.texture is not None and base.color == (1.0, 1.0, 1.0, 1.0)
    texels = sample(decoded(base.texture), base.visual.uv)
    high = base.visual.vertices[:, 2]
    _, b_px = noise_png(6, 2, 1)
    tinted_b = linear_to_srgb(srgb_to_linear(sample(b_px, texel_centres(6, 2, 4, 1))[:, :3]
                                             / 255) * [1, 0.5, 0.5]) * 255
    on_b = (high > 1.5) & (high < 3.5)
    assert on_b.sum() == 4
    assert np.abs(np.sort(texels[on_b, :3], axis=0) - np.sort(tinted_b, axis=0)).max() <= 0.5
    assert (texels[high > 3.4, :3] == [0, 255, 0]).all()  # the box: green, sRGB-encoded
    before = _face_texels(base)
    for fmt, path in export(obj, tmp_path / "out", ["mjcf", "usd", "gltf"]).items():
        assert np.array_equal(_face_texels(load(path).part("base")), before), fmt


def test_a_usd_body_of_meshes_bound_to_their_own_images_keeps_them(tmp_path):
    """Isaac Sim's assets bind a material per mesh: a body of two meshes, each bound to its
    own UsdPreviewSurface with an image, and a red one, reads as one part with one image."""
    from pxr import Gf, Sdf, Usd, UsdGeom, UsdPhysics, UsdShade, Vt

    from real2code_export.formats import export, load

    stage = Usd.Stage.CreateNew(str(tmp_path / "b.usda"))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    body = UsdGeom.Xform.Define(stage, "/r/body")
    stage.SetDefaultPrim(stage.GetPrimAtPath("/r"))
    UsdPhysics.RigidBodyAPI.Apply(body.GetPrim())
    mass = UsdPhysics.MassAPI.Apply(body.GetPrim())
    mass.CreateMassAttr(1.0)
    mass.CreateDiagonalInertiaAttr(Gf.Vec3f(0.1, 0.1, 0.1))
    mass.CreateCenterOfMassAttr(Gf.Vec3f(0, 0, 0))
    corners = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)]
    faces = [0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3]
    for k, (name, size) in enumerate((("a", (4, 4)), ("b", (6, 2)), ("red", None))):
        mesh = UsdGeom.Mesh.Define(stage, f"/r/body/{name}")
        mesh.CreatePointsAttr([Gf.Vec3f(x, y, z + 2 * k) for x, y, z in corners])
        mesh.CreateFaceVertexCountsAttr([3] * 4)
        mesh.CreateFaceVertexIndicesAttr(faces)
        material = UsdShade.Material.Define(stage, f"/r/Looks/{name}")
        surface = UsdShade.Shader.Define(stage, f"/r/Looks/{name}/Surface")
        surface.CreateIdAttr("UsdPreviewSurface")
        material.CreateSurfaceOutput().ConnectToSource(surface.ConnectableAPI(), "surface")
        if size is None:
            surface.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set((1, 0, 0))
        else:
            data, _ = noise_png(*size, k)
            (tmp_path / f"{name}.png").write_bytes(data)
            uv = texel_centres(*size, 4, k)
            st = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar(
                "st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex)
            st.Set(Vt.Vec2fArray.FromNumpy(uv.astype(np.float32)))
            reader = UsdShade.Shader.Define(stage, f"/r/Looks/{name}/st")
            reader.CreateIdAttr("UsdPrimvarReader_float2")
            reader.CreateInput("varname", Sdf.ValueTypeNames.String).Set("st")
            image = UsdShade.Shader.Define(stage, f"/r/Looks/{name}/Image")
            image.CreateIdAttr("UsdUVTexture")
            image.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(f"./{name}.png")
            image.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(
                reader.ConnectableAPI(), "result")
            surface.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(
                image.ConnectableAPI(), "rgb")
        UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(material)
    stage.Save()
    with pytest.warns(Real2CodeWarning, match=r"3 visual mesh\(es\) and their subsets packed into one image"):
        obj = load(tmp_path / "b.usda")
    part = obj.part("body")  # (free: hung from a massless 'world')
    assert part.texture is not None and part.color == (1.0, 1.0, 1.0, 1.0)
    texels = sample(decoded(part.texture), part.visual.uv)
    high = part.visual.vertices[:, 2]
    _, a_px = noise_png(4, 4, 0)
    assert np.array_equal(np.sort(texels[high < 1.5], axis=0),
                          np.sort(sample(a_px, texel_centres(4, 4, 4, 0)), axis=0))
    assert (texels[high > 3.9, :3] == [255, 0, 0]).all()
    before = _face_texels(part)
    for fmt, path in export(obj, tmp_path / "out", ["usd", "gltf"]).items():
        assert np.array_equal(_face_texels(load(path).part("body")), before), fmt


def test_the_shelves_hold_every_tile_apart_inside_the_atlas():
    from real2code_export.texture_atlas import shelf_layout

    sizes = [tuple(int(v) for v in s)
             for s in np.random.default_rng(0).integers(1, 300, (40, 2))] + [(9, 9)] * 5
    corners, (width, height) = shelf_layout(sizes)
    boxes = [(x, y, x + w, y + h) for (x, y), (w, h) in zip(corners, sizes, strict=True)]
    assert all(min(a, b) >= 0 and c <= width and d <= height for a, b, c, d in boxes)
    for i, (a, b, c, d) in enumerate(boxes):
        for e, f, g, h in boxes[i + 1:]:
            assert c <= e or g <= a or d <= f or h <= b  # apart
    assert width * height <= 2 * sum(w * h for w, h in sizes)  # not wasteful


def test_a_usd_mesh_whose_subsets_bind_images_keeps_them(tmp_path):
    """GeomSubsets of the materialBind family bind two textured materials to the faces of
    one mesh (the mesh itself binds none): read as one image, each face drawing its own
    material's texels (they were dropped in silence)."""
    from pxr import Gf, Sdf, Usd, UsdGeom, UsdPhysics, UsdShade, Vt

    from real2code_export.formats import load

    stage = Usd.Stage.CreateNew(str(tmp_path / "s.usda"))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    body = UsdGeom.Xform.Define(stage, "/r/body")
    stage.SetDefaultPrim(stage.GetPrimAtPath("/r"))
    UsdPhysics.RigidBodyAPI.Apply(body.GetPrim())
    UsdPhysics.MassAPI.Apply(body.GetPrim()).CreateMassAttr(1.0)
    mesh = UsdGeom.Mesh.Define(stage, "/r/body/m")
    mesh.CreatePointsAttr([Gf.Vec3f(0, 0, 0), Gf.Vec3f(1, 0, 0), Gf.Vec3f(0, 1, 0),
                           Gf.Vec3f(0, 0, 1)])
    mesh.CreateFaceVertexCountsAttr([3] * 4)
    mesh.CreateFaceVertexIndicesAttr([0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3])
    UsdGeom.PrimvarsAPI(mesh).CreatePrimvar(
        "st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex).Set(
        Vt.Vec2fArray([(0.1, 0.1), (0.9, 0.1), (0.1, 0.9), (0.9, 0.9)]))
    colours = {"a": (200, 50, 50), "b": (20, 60, 220)}
    from PIL import Image

    for k, (name, rgb) in enumerate(colours.items()):
        Image.fromarray(np.full((4, 4, 3), rgb, np.uint8)).save(tmp_path / f"{name}.png")
        material = UsdShade.Material.Define(stage, f"/r/Looks/{name}")
        surface = UsdShade.Shader.Define(stage, f"/r/Looks/{name}/Surface")
        surface.CreateIdAttr("UsdPreviewSurface")
        material.CreateSurfaceOutput().ConnectToSource(surface.ConnectableAPI(), "surface")
        image = UsdShade.Shader.Define(stage, f"/r/Looks/{name}/Image")
        image.CreateIdAttr("UsdUVTexture")
        image.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(f"./{name}.png")
        surface.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(
            image.ConnectableAPI(), "rgb")
        subset = UsdGeom.Subset.Define(stage, f"/r/body/m/faces_{name}")
        subset.CreateElementTypeAttr("face")
        subset.CreateFamilyNameAttr("materialBind")
        subset.CreateIndicesAttr([2 * k, 2 * k + 1])
        UsdShade.MaterialBindingAPI.Apply(subset.GetPrim()).Bind(material)
    stage.Save()
    with pytest.warns(Real2CodeWarning, match="subsets packed into one image"):
        part = load(tmp_path / "s.usda").part("body")
    texels = sample(decoded(part.texture), part.visual.uv[part.visual.faces].mean(axis=1))
    assert [tuple(t[:3]) for t in texels] == [colours["a"]] * 2 + [colours["b"]] * 2


def test_a_gltf_mesh_whose_primitives_have_their_own_images_keeps_them(tmp_path):
    """Another tool's glTF: one mesh of two primitives, each material with its own base
    colour image (the second tinted by its factor): one part, one image (the second
    primitive's image was dropped in silence: the first primitive's material was read)."""
    import pygltflib as g

    from real2code_export.formats import load

    blob, views, accessors = bytearray(), [], []

    def view(data: bytes) -> int:
        views.append(g.BufferView(buffer=0, byteOffset=len(blob), byteLength=len(data)))
        blob.extend(data + b"\0" * (-len(data) % 4))
        return len(views) - 1

    def accessor(array: np.ndarray, kind: str, component: int) -> int:
        accessors.append(g.Accessor(bufferView=view(array.tobytes()), componentType=component,
                                    count=len(array), type=kind,
                                    **({"min": array.min(0).tolist(), "max": array.max(0).tolist()}
                                       if kind == "VEC3" else {})))
        return len(accessors) - 1

    pngs = [noise_png(4, 4, 0), noise_png(6, 2, 1)]
    uvs = [texel_centres(4, 4, 3, 0), texel_centres(6, 2, 3, 1)]
    primitives, materials, images, textures = [], [], [], []
    for k, ((data, _), uv) in enumerate(zip(pngs, uvs, strict=True)):
        positions = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32) + [0, 0, 2 * k]
        flipped = np.column_stack([uv[:, 0], 1 - uv[:, 1]]).astype(np.float32)  # glTF: v down
        images.append(g.Image(bufferView=view(data), mimeType="image/png"))
        textures.append(g.Texture(source=k))
        materials.append(g.Material(pbrMetallicRoughness=g.PbrMetallicRoughness(
            baseColorTexture=g.TextureInfo(index=k),
            baseColorFactor=[1.0, 1.0, 1.0, 1.0] if k == 0 else [1.0, 0.5, 0.5, 1.0])))
        primitives.append(g.Primitive(
            attributes=g.Attributes(POSITION=accessor(positions.astype(np.float32), "VEC3",
                                                      g.FLOAT),
                                    TEXCOORD_0=accessor(flipped, "VEC2", g.FLOAT)),
            indices=accessor(np.array([0, 1, 2], np.uint32), "SCALAR", g.UNSIGNED_INT),
            material=k))
    gltf = g.GLTF2(asset=g.Asset(version="2.0"), scene=0, scenes=[g.Scene(nodes=[0])],
                   nodes=[g.Node(name="thing", mesh=0)],
                   meshes=[g.Mesh(primitives=primitives)], materials=materials,
                   images=images, textures=textures, accessors=accessors, bufferViews=views,
                   buffers=[g.Buffer(byteLength=len(blob))])
    gltf.set_binary_blob(bytes(blob))
    gltf.save_binary(str(tmp_path / "thing.glb"))
    with pytest.warns(Real2CodeWarning, match="2 primitives packed into one image"):
        part = load(tmp_path / "thing.glb").parts[0]
    texels = sample(decoded(part.texture), part.visual.uv)
    first = part.visual.vertices[:, 1] > -1  # (glTF's z is the model's -y)
    assert first.sum() == 3
    assert np.array_equal(np.sort(texels[first], axis=0),
                          np.sort(sample(pngs[0][1], uvs[0]), axis=0))
    tinted = linear_to_srgb(srgb_to_linear(sample(pngs[1][1], uvs[1])[:, :3] / 255)
                            * [1, 0.5, 0.5]) * 255
    assert np.abs(np.sort(texels[~first, :3], axis=0) - np.sort(tinted, axis=0)).max() \
        <= 0.5 + 1e-9


def test_an_obj_of_an_image_with_coordinates_beside_a_colour_without_keeps_the_image(tmp_path):
    """PartNet-Mobility's layout: the faces of the image's material have ``vt``, the faces of
    a plain material have none (``f 5//1 6//1 7//1``). The image was not kept ("without
    texture coordinates on every face"); now it is, beside the colour."""
    data, pixels = noise_png(4, 4, 0)
    (tmp_path / "a.png").write_bytes(data)
    (tmp_path / "m.mtl").write_text("newmtl a\nKd 1 1 1\nmap_Kd a.png\nnewmtl b\nKd 1 0 0\n")
    uv = texel_centres(4, 4, 3, 0)
    (tmp_path / "m.obj").write_text(
        "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nv 3 0 0\nv 2 1 0\nvn 0 0 1\n"
        + "".join(f"vt {u:.6f} {v:.6f}\n" for u, v in uv)
        + "usemtl a\nf 1/1/1 2/2/1 3/3/1\nusemtl b\nf 4//1 5//1 6//1\n")
    with pytest.warns(Real2CodeWarning, match="1 image.* and 1 other colour.*packed into one"):
        part = one_link(tmp_path, "m.obj")
    drawn = sample(decoded(part.texture), part.visual.uv)
    left = part.visual.vertices[:, 0] < 1.5
    assert np.array_equal(np.sort(drawn[left], axis=0), np.sort(sample(pixels, uv), axis=0))
    assert (drawn[~left] == [255, 0, 0, 255]).all()


def test_without_its_image_such_an_obj_reads_as_before(tmp_path):
    """The same OBJ where the image is not there (PartNet-Mobility copies without
    ``images/``): no texture coordinates, corners not split, the colours kept."""
    from real2code_export.meshfiles import read_mesh_file

    (tmp_path / "m.mtl").write_text("newmtl a\nKd 1 1 1\nmap_Kd gone.png\nnewmtl b\nKd 1 0 0\n")
    (tmp_path / "m.obj").write_text(
        "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 0 1\n"
        "usemtl a\nf 1/1 2/2 3/3\nusemtl b\nf 2 4 3\n")
    with pytest.warns(Real2CodeWarning, match="not kept"):
        read = read_mesh_file(tmp_path / "m.obj")
    assert read.texture is None and read.mesh.uv is None and len(read.mesh.vertices) == 4
