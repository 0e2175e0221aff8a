"""A 2D image on an MJCF mesh without texture coordinates: MuJoCo's renderer projects it
along the mesh's z (geometry.projected_uv). Read, the mesh gets those coordinates, so every
format shows what MuJoCo showed: the MJCF written back, with them in its mesh file, renders
as the source does."""

from __future__ import annotations

import io
import os
import warnings

import numpy as np
import pytest

from real2code_export.errors import Real2CodeWarning
from real2code_export.formats import export, load

QUADRANTS = [[(220, 30, 30), (30, 200, 40)], [(30, 60, 220), (240, 220, 30)]]

MODEL = """<mujoco model="stamp">
  <compiler texturedir="." angle="radian"/>
  <asset>
    <texture name="quads" type="2d" colorspace="sRGB" file="quads.png"/>
    <material name="stamped" texture="quads" texrepeat="{repeat}" texuniform="{uniform}"/>
    <mesh name="slab" vertex="{vertex}" face="{face}"/>
  </asset>
  <worldbody>
    <body name="base">
      <inertial pos="0 0 0" mass="1" diaginertia="0.1 0.1 0.1"/>
      <geom type="mesh" mesh="slab" material="stamped" contype="0" conaffinity="0"/>
    </body>
  </worldbody>
</mujoco>
"""


def slab() -> tuple[np.ndarray, np.ndarray]:
    """A lopsided slab (wider than deep, a slanted top) seen from above: a subdivided grid
    on top so the projection is sampled across it."""
    n = 8
    xs, ys = np.meshgrid(np.linspace(-0.3, 0.5, n), np.linspace(-0.2, 0.1, n), indexing="ij")
    top = np.column_stack([xs.ravel(), ys.ravel(), 0.05 + 0.1 * xs.ravel()])
    bottom = top * [1, 1, 0] - [0, 0, 0.05]
    vertices = np.vstack([top, bottom])
    faces = []
    for i in range(n - 1):
        for j in range(n - 1):
            a, b, c, d = i * n + j, (i + 1) * n + j, (i + 1) * n + j + 1, i * n + j + 1
            faces += [(a, b, c), (a, c, d)]
            faces += [(a + n * n, c + n * n, b + n * n), (a + n * n, d + n * n, c + n * n)]
    return vertices, np.array(faces)


def quadrants_png() -> bytes:
    from PIL import Image

    pixels = np.zeros((32, 32, 3), dtype=np.uint8)  # (square: a cube texture too)
    for r in range(2):
        for c in range(2):
            pixels[r * 16:(r + 1) * 16, c * 16:(c + 1) * 16] = QUADRANTS[r][c]
    buffer = io.BytesIO()
    Image.fromarray(pixels).save(buffer, format="PNG")
    return buffer.getvalue()


def render_from_above(path) -> np.ndarray:
    import mujoco

    model = mujoco.MjModel.from_xml_path(str(path))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    camera = mujoco.MjvCamera()
    camera.lookat[:] = (0.1, -0.05, 0.0)
    camera.distance, camera.elevation, camera.azimuth = 1.2, -90.0, 90.0
    with mujoco.Renderer(model, 96, 128) as renderer:
        renderer.update_scene(data, camera)
        return renderer.render().astype(np.float64)


@pytest.mark.skipif(os.environ.get("MUJOCO_GL") not in ("osmesa", "egl"),
                    reason="needs MuJoCo's offscreen renderer (MUJOCO_GL=osmesa or egl)")
@pytest.mark.parametrize(("repeat", "uniform"), [("1 1", "false"), ("2 3", "false"),
                                                 ("4 2", "true")])
def test_a_projected_texture_reads_and_writes_as_mujoco_draws_it(tmp_path, repeat, uniform):
    vertices, faces = slab()
    source = tmp_path / "stamp.xml"
    (tmp_path / "quads.png").write_bytes(quadrants_png())
    source.write_text(MODEL.format(repeat=repeat, uniform=uniform,
                                   vertex=" ".join(f"{x:.6f}" for x in vertices.ravel()),
                                   face=" ".join(str(i) for i in faces.ravel())))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", Real2CodeWarning)
        obj = load(source)
    part = obj.part("base")
    assert part.texture is not None and part.visual.uv is not None
    written = export(obj, tmp_path / "out", ["mjcf", "gltf", "usd"])
    drawn, again = render_from_above(source), render_from_above(written["mjcf"])
    # past one copy, USD is told to repeat the image as MuJoCo and glTF do (its default,
    # for an image without the metadata, is black there)
    from pxr import Usd, UsdShade

    stage = Usd.Stage.Open(str(written["usd"]))
    wraps = {UsdShade.Shader(p).GetInput("wrapS").Get() for p in stage.Traverse()
             if UsdShade.Shader(p) and UsdShade.Shader(p).GetIdAttr().Get() == "UsdUVTexture"}
    past = part.visual.uv.min() < 0.0 or part.visual.uv.max() > 1.0
    assert wraps == ({"repeat"} if past else {None}), (wraps, repeat)
    # the image's colours where MuJoCo drew them: a flipped or shifted projection moves
    # whole quadrants (differences of ~150 on a channel), texel filtering a few levels
    assert np.abs(drawn - again).mean() < 3.0, np.abs(drawn - again).mean()
    assert np.abs(drawn - drawn.mean(axis=(0, 1))).mean() > 8  # (the image is drawn)


@pytest.mark.parametrize(("texture", "geom", "said"), [
    ('type="2d"', 'type="box" size="0.1 0.1 0.01"', "primitive geom"),
    ('type="cube"', 'type="mesh" mesh="slab"', "cube texture")])
def test_an_image_mujoco_places_otherwise_is_warned_about_saying_how(tmp_path, texture, geom,
                                                                     said):
    vertices, faces = slab()
    (tmp_path / "quads.png").write_bytes(quadrants_png())
    text = MODEL.format(repeat="1 1", uniform="false",
                        vertex=" ".join(f"{x:.6f}" for x in vertices.ravel()),
                        face=" ".join(str(i) for i in faces.ravel()))
    text = text.replace('type="2d"', texture).replace('type="mesh" mesh="slab"', geom)
    (tmp_path / "m.xml").write_text(text)
    with pytest.warns(Real2CodeWarning, match=f"textures not kept .*{said}"):
        part = load(tmp_path / "m.xml").part("base")
    assert part.texture is None
