"""Texture baking (pipeline/texture.py): a tiled floor seen by a camera from above. Every
texel takes the colour the view shows at its surface point; texels no view saw take the
nearest seen colour; a part no view sees keeps its flat colour."""

from __future__ import annotations

import io

import numpy as np

from pipeline.capture import Camera, Capture, Frame
from pipeline.render import look_at
from pipeline.texture import BakeOptions, bake_textures
from real2code_export.model import ArticulatedObject, Joint, JointType, Mesh, Part

SIZE = 64
RED, BLUE = (220, 30, 30), (30, 30, 220)


def floor(size: float = 1.0, n: int = 8) -> Mesh:
    """A square of 2 n^2 triangles in z = 0."""
    xs = np.linspace(-size / 2, size / 2, n + 1)
    grid = np.array([[x, y, 0.0] for y in xs for x in xs])
    faces = []
    for r in range(n):
        for c in range(n):
            a = r * (n + 1) + c
            faces += [(a, a + 1, a + n + 2), (a, a + n + 2, a + n + 1)]
    return Mesh(grid, np.array(faces))


def top_view(hidden_part_box: bool = False) -> Frame:
    """From 2 m above, looking down: x < 0 red, x >= 0 blue; depth 2 m where the floor is."""
    f = 0.5 * SIZE / np.tan(np.radians(40) / 2)
    camera = Camera(f, f, SIZE / 2, SIZE / 2, SIZE, SIZE)
    pose = look_at(np.array([0.0, 0.0, 2.0]), np.zeros(3), up=(0.0, 1.0, 0.0))
    rgb = np.zeros((SIZE, SIZE, 3), dtype=np.uint8)
    # pixel columns map to world x (look_at: camera x = world x from above with y up)
    rgb[:, : SIZE // 2] = RED
    rgb[:, SIZE // 2:] = BLUE
    depth = np.full((SIZE, SIZE), 2.0, dtype=np.float32)
    return Frame(camera, pose, rgb, depth)


def texel_at(part: Part, point: np.ndarray) -> np.ndarray:
    """The baked colour at a point on the part's (flat) surface."""
    from PIL import Image

    image = np.asarray(Image.open(io.BytesIO(part.texture.image)).convert("RGB"))
    mesh = part.visual
    for face in mesh.faces:
        a, b, c = mesh.vertices[face][:, :2]
        m = np.array([b - a, c - a]).T
        s, t = np.linalg.solve(m, point[:2] - a)
        if s >= 0 and t >= 0 and s + t <= 1:
            uv = (1 - s - t) * mesh.uv[face[0]] + s * mesh.uv[face[1]] + t * mesh.uv[face[2]]
            size = image.shape[0]
            row = min(size - 1, int((1.0 - uv[1]) * size))
            col = min(size - 1, int(uv[0] * size))
            return image[row, col]
    raise AssertionError(f"{point} is not on the part")


def test_each_texel_takes_the_colour_its_view_shows():
    body = Part("floor", floor(), color=(0.5, 0.5, 0.5, 1.0))
    below = Part("below", floor(0.4).transformed(np.diag([1.0, 1.0, 1.0, 1.0])))
    origin = np.eye(4)
    origin[:3, 3] = (0.0, 0.0, -0.5)  # under the floor: hidden from the camera
    obj = ArticulatedObject("scene", [body, below],
                            [Joint("fixed", JointType.FIXED, "floor", "below", origin)])
    baked = bake_textures(obj, Capture([top_view()]), options=BakeOptions(size=128))
    part = baked.part("floor")
    assert part.texture is not None and part.texture.mime == "image/png"
    assert part.color[:3] == (1.0, 1.0, 1.0)  # the texture shows as captured
    for x in (-0.4, -0.2, -0.05):
        assert tuple(texel_at(part, np.array([x, 0.1, 0.0]))) == RED, x
    for x in (0.05, 0.2, 0.4):
        assert tuple(texel_at(part, np.array([x, -0.1, 0.0]))) == BLUE, x
    # the part under the floor is hidden (its depth disagrees with the view's): flat colour
    assert baked.part("below").texture is None
    assert baked.part("below").color == obj.part("below").color


def test_labels_keep_a_view_from_painting_another_part():
    obj = ArticulatedObject("scene", [Part("floor", floor())], [])
    frame = top_view()
    other_part = np.full((SIZE, SIZE), 2, dtype=np.uint16)
    other_part[:, : SIZE // 2] = 1  # the segmentation saw the floor only on the left
    baked = bake_textures(obj, Capture([frame]), labels={"floor": (1, [other_part])},
                          options=BakeOptions(size=128))
    part = baked.part("floor")
    # the right half was not seen as this part: filled from the nearest seen texel (red)
    assert tuple(texel_at(part, np.array([0.3, 0.0, 0.0]))) == RED
