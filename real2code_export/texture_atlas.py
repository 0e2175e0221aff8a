"""Several images and colours on one part as one image: a texture atlas.

A part holds one colour image over one mesh's texture coordinates (:class:`model.Part`), as
one glTF material, one USD preview surface or one MuJoCo material does. Real files give a part
more: a link whose visuals each bring their own image (a scanned object's OBJs, a robot's
Collada meshes), a Collada mesh of a textured primitive beside coloured ones, an OBJ whose MTL
names several ``map_Kd``, a USD body's meshes or a glTF mesh's primitives each with their
own material. Here those pieces become one mesh with one image: each image (its
tint multiplied in) and each flat colour (a tile of one pixel) laid out side by side on shelves,
the texture coordinates moved into their tile. An image that repeats
over its triangles (coordinates past [0, 1], as tiling wood grain is mapped) is unrolled first,
as many copies as its coordinates span, since a tile in an atlas cannot repeat.

Colours follow glTF 2.0: a factor is linear, an image's texels sRGB-encoded, so a tint
multiplies the decoded texel and a flat colour is encoded into its tile; glTF and USD viewers
decode the image and draw the same colours as before packing (the MJCF writer declares the
image sRGB to MuJoCo, its colour space).
"""

from __future__ import annotations

import io
from dataclasses import dataclass

import numpy as np

from .model import RGBA, Mesh, Texture

ATLAS_NAME = "atlas"
MAX_UNROLLED_SIDE = 4096  # pixels: an unrolled repeating image beyond it is scaled down
MAX_ATLAS_SIDE = 8192  # pixels: what GPUs and glTF viewers commonly take
PADDING = 4  # pixels of each tile's edge repeated around it
_HALF_PIXEL_SLACK = 1e-3  # coordinates this far past [0, 1] are the edge, not a repeat


@dataclass(eq=False)
class AtlasPiece:
    """Faces to draw from one image or in one colour: ``mesh`` with texture coordinates where
    ``texture`` is given; ``color`` the tint that multiplies the image, or the flat colour."""

    mesh: Mesh
    texture: Texture | None
    color: RGBA


@dataclass(eq=False)
class Atlas:
    """The pieces' meshes joined in order, with texture coordinates into ``texture``;
    ``notes`` say what packing changed (an image scaled down, a repeat unrolled)."""

    mesh: Mesh
    texture: Texture
    notes: list[str]


def faces_of(mesh: Mesh, start: int, end: int) -> Mesh:
    """Faces ``start:end`` of ``mesh`` with the vertices (and texture coordinates) they use,
    in order: one run of a mesh drawn by several materials."""
    faces = mesh.faces[start:end]
    used = np.zeros(len(mesh.vertices), dtype=bool)
    used[faces.ravel()] = True
    index = np.flatnonzero(used)
    renumber = np.cumsum(used) - 1
    return Mesh(mesh.vertices[index], renumber[faces],
                None if mesh.uv is None else mesh.uv[index])


def needs_atlas(pieces: list[AtlasPiece]) -> bool:
    """Whether the pieces need more than one image with one tint to be drawn as read: two
    images, or an image beside faces of another colour."""
    images = {_image_key(p.texture) for p in pieces if p.texture is not None}
    if len(images) != 1:
        return len(images) > 1
    return len({(p.texture is None, p.color) for p in pieces}) > 1


def pack(pieces: list[AtlasPiece]) -> Atlas:
    """One image for all the pieces (:func:`needs_atlas`), as PNG (lossless: each tile keeps
    its pixels, unless the atlas would pass :data:`MAX_ATLAS_SIDE`, when every tile is
    scaled down alike, said in ``notes``). Raises ValueError for a textured piece without
    texture coordinates."""
    from PIL import Image

    notes: list[str] = []
    tiles: dict[tuple, int] = {}  # (image, tint) or colour -> its index in ``images``
    images, uvs, tile_of = [], [], []
    drawn: dict[tuple, object] = {}  # (image digest, tint) -> the image as drawn
    for piece in pieces:
        if piece.texture is None:
            key = ("colour", piece.color)
            if key not in tiles:
                texel = np.round(np.append(linear_to_srgb(np.asarray(piece.color[:3])),
                                           piece.color[3]) * 255).astype(np.uint8)
                tiles[key] = len(images)
                images.append(Image.new("RGBA", (1, 1), tuple(int(c) for c in texel)))
            uvs.append(np.full((len(piece.mesh.vertices), 2), 0.5))
            tile_of.append(tiles[key])
            continue
        if piece.mesh.uv is None:
            raise ValueError(f"image {piece.texture.name!r} on faces without texture "
                             "coordinates")
        look = (piece.texture.digest, piece.color)  # (an image several pieces show: once)
        if look not in drawn:
            drawn[look] = _tinted(_decoded(piece.texture), piece.color)
        image, uv = _unrolled(drawn[look], piece.mesh.uv, piece.texture.name, notes)
        key = ("image", image.size, image.tobytes())
        if key not in tiles:
            tiles[key] = len(images)
            images.append(image)
        uvs.append(uv)
        tile_of.append(tiles[key])
    atlas, boxes = _packed(images, notes)
    width, height = atlas.size
    moved = []
    for uv, k in zip(uvs, tile_of, strict=True):
        x, y, w, h = boxes[k]  # the tile's pixels, from the atlas's bottom-left corner
        moved.append(np.column_stack([(x + uv[:, 0] * w) / width, (y + uv[:, 1] * h) / height]))
    buffer = io.BytesIO()
    atlas.save(buffer, format="PNG")
    joined = Mesh.concatenate([Mesh(p.mesh.vertices, p.mesh.faces) for p in pieces])
    return Atlas(Mesh(joined.vertices, joined.faces, np.concatenate(moved)),
                 Texture(buffer.getvalue(), "image/png", ATLAS_NAME), notes)


def _packed(images: list, notes: list[str]):
    """The tiles in one RGBA image (:func:`shelf_layout`), each tile's edge pixels repeated
    :data:`PADDING` pixels out so a filtering sampler at its edge blends its own colour, not a
    neighbour's. Returns the image and each tile's (x, y, width, height) in pixels from the
    bottom-left corner. (trimesh's ``material.pack`` pads with nothing, maps coordinates by
    ``(size - 1)``, half a texel off glTF's and OpenGL's sampling, and importing trimesh and
    scipy for it cost a command up to two seconds: so the layout is done here.)"""
    from PIL import Image

    scale = 1.0
    while True:
        sized = images if scale == 1.0 else [
            im.resize((max(1, round(im.size[0] * scale)), max(1, round(im.size[1] * scale))),
                      Image.Resampling.LANCZOS) if max(im.size) > 1 else im for im in images]
        padded = [(im.size[0] + 2 * PADDING, im.size[1] + 2 * PADDING) for im in sized]
        corners, (width, height) = shelf_layout(padded)
        if max(width, height) <= MAX_ATLAS_SIDE:
            break
        scale *= 0.5
    if scale < 1.0:
        notes.append(f"images scaled to {scale:g} of their resolution to fit one atlas of at "
                     f"most {MAX_ATLAS_SIDE} pixels a side")
    atlas = Image.new("RGBA", (width, height))
    for im, (x, y) in zip(sized, corners, strict=True):
        tile = np.pad(np.asarray(im), ((PADDING, PADDING), (PADDING, PADDING), (0, 0)),
                      mode="edge")
        atlas.paste(Image.fromarray(tile, "RGBA"), (x, height - y - tile.shape[0]))
    boxes = [(x + PADDING, y + PADDING, im.size[0], im.size[1])
             for (x, y), im in zip(corners, sized, strict=True)]
    return atlas, boxes


def shelf_layout(sizes: list[tuple[int, int]]) -> tuple[list[tuple[int, int]], tuple[int, int]]:
    """Rectangles (width, height) laid out without overlap on shelves, tallest first, each
    shelf filled left to right up to a width near the square root of their area (next-fit
    decreasing height): each one's bottom-left corner and the whole (width, height)."""
    area = sum(w * h for w, h in sizes)
    limit = max(max(w for w, _ in sizes), int(np.ceil(np.sqrt(area))))
    corners = [(0, 0)] * len(sizes)
    x = y = shelf = width = 0
    for k in sorted(range(len(sizes)), key=lambda k: (-sizes[k][1], k)):
        w, h = sizes[k]
        if x + w > limit:  # the next shelf
            x, y, shelf = 0, y + shelf, 0
        corners[k] = (x, y)
        x, shelf, width = x + w, max(shelf, h), max(width, x + w)
    return corners, (width, y + shelf)


def linear_to_srgb(c: np.ndarray) -> np.ndarray:
    """The sRGB encoding of linear values in [0, 1] (IEC 61966-2-1)."""
    c = np.clip(np.asarray(c, dtype=np.float64), 0.0, 1.0)
    return np.where(c <= 0.0031308, 12.92 * c, 1.055 * c ** (1 / 2.4) - 0.055)


def srgb_to_linear(c: np.ndarray) -> np.ndarray:
    c = np.clip(np.asarray(c, dtype=np.float64), 0.0, 1.0)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def _image_key(texture: Texture) -> bytes:
    return texture.image


def _decoded(texture: Texture):
    from PIL import Image

    return Image.open(io.BytesIO(texture.image)).convert("RGBA")


def _tinted(image, color: RGBA):
    """The image as the tint draws it: each texel decoded, multiplied, encoded again (a white
    tint leaves the pixels as they are), through one table of the 256 values per channel."""
    if all(c == 1.0 for c in color):
        return image
    levels = np.arange(256) / 255
    tables = [linear_to_srgb(srgb_to_linear(levels) * c) for c in color[:3]]
    tables.append(levels * color[3])  # (alpha is linear)
    lut = np.round(np.concatenate(tables) * 255).astype(np.uint8)
    return image.point(lut.tolist())


def _unrolled(image, uv: np.ndarray, name: str, notes: list[str]):
    """The image and coordinates of a piece whose coordinates span more than one copy of its
    image (a repeat): copies side by side over the span, the coordinates scaled into them.
    A whole-number shift changes nothing a repeating sampler draws, so the span starts at
    the copy the lowest coordinate falls in."""
    from PIL import Image

    low = np.floor(uv.min(axis=0) + _HALF_PIXEL_SLACK)
    shifted = uv - low
    copies = np.maximum(1, np.ceil(shifted.max(axis=0) - _HALF_PIXEL_SLACK)).astype(int)
    if (copies == 1).all():
        return image, np.clip(shifted, 0.0, 1.0)
    width, height = image.size
    tiled = Image.new("RGBA", (width * copies[0], height * copies[1]))
    for i in range(copies[0]):
        for j in range(copies[1]):  # (v up: copy j from the bottom)
            tiled.paste(image, (i * width, (copies[1] - 1 - j) * height))
    scale = min(1.0, MAX_UNROLLED_SIDE / max(tiled.size))
    if scale < 1.0:
        tiled = tiled.resize((max(1, round(tiled.size[0] * scale)),
                              max(1, round(tiled.size[1] * scale))), Image.Resampling.LANCZOS)
        notes.append(f"image {name!r} repeats {copies[0]} x {copies[1]} times over its "
                     f"faces: unrolled at {scale:.2f} of its resolution")
    return tiled, np.clip(shifted / copies, 0.0, 1.0)
