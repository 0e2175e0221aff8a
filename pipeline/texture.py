"""Texture baking: the capture's colours onto each reconstructed part.

Each part's visual mesh is decimated (open3d) and unwrapped into its own UV atlas (xatlas, the
unwrapper trimesh uses); every texel centre is placed on the surface (at the capture's
joint state, in the capture's world frame) and takes its colour from the view that sees it
best: in front of the camera, within the view, not hidden (the view's depth agrees with the
texel's), labelled as this part by the segmentation where the view has labels, and scored
by how squarely and how closely the camera faces it. Texels no view saw, and the gutter
between charts, take the colour of the nearest seen texel (so mipmaps and bilinear filtering
do not bleed the background in); a part no view saw keeps its flat colour.

The image is sRGB (the capture's own encoding, as glTF's baseColorTexture expects) and the
part's colour becomes white: a format's colour multiplies the texture (glTF's factor,
MuJoCo's material rgba), so white shows the image as captured.
"""

from __future__ import annotations

import io
from dataclasses import dataclass, replace

import numpy as np

from real2code_export.model import ArticulatedObject, Mesh, Part, Texture, forward_kinematics

from .capture import Capture

WHITE = (1.0, 1.0, 1.0)


@dataclass(frozen=True)
class BakeOptions:
    size: int = 512  # atlas side, texels
    max_faces: int = 6000  # the textured visual mesh is decimated to this many faces
    depth_tolerance: float = 0.02  # m: completed surfaces sit near, not on, the measured one
    depth_tolerance_relative: float = 0.03  # of the distance to the camera
    min_facing: float = 0.15  # cos of the steepest view angle a texel takes colour from


def bake_textures(obj: ArticulatedObject, capture: Capture,
                  labels: dict[str, tuple[int, list[np.ndarray]]] | None = None,
                  options: BakeOptions = BakeOptions()) -> ArticulatedObject:
    """``obj`` with every visual part textured from ``capture``. ``labels``: part name ->
    (its label, the per-view label images) from the segmentation, so a view paints a part
    only where it saw that part."""
    poses = forward_kinematics(obj, obj.observed_configuration())
    parts = []
    for part in obj.parts:
        if part.visual is None or len(part.visual.faces) == 0:
            parts.append(part)
            continue
        mine = labels.get(part.name) if labels else None
        parts.append(bake_part(part, poses[part.name], capture, mine, options))
    return replace(obj, parts=parts)


def bake_part(part: Part, pose: np.ndarray, capture: Capture,
              labels: tuple[int, list[np.ndarray]] | None, options: BakeOptions) -> Part:
    mesh = unwrap(part.visual, options.max_faces)
    texel_uv, face, bary = rasterize(mesh, options.size)
    tri = mesh.vertices[mesh.faces[face]]
    local = np.einsum("nk,nkd->nd", bary, tri)
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-20)
    world = local @ pose[:3, :3].T + pose[:3, 3]
    normal = normal @ pose[:3, :3].T
    colour, seen = sample_views(world, normal, capture, labels, options)
    if not seen.any():  # no view saw it: the part keeps its flat colour
        return part
    image = fill(texel_uv, colour, seen, options.size)
    return replace(part, visual=mesh, color=(*WHITE, part.color[3]),
                   texture=Texture(png(image), "image/png", f"{part.name}_baked"))


def unwrap(mesh: Mesh, max_faces: int) -> Mesh:
    """The mesh cut into charts and laid out in [0, 1]^2 (vertices on seams duplicated),
    first decimated to ``max_faces`` (open3d's quadric decimation): a completed part is a
    marching-cubes surface of tens of thousands of faces whose noisy normals make xatlas cut
    a thousand charts and take a minute; the texture carries the detail instead."""
    import xatlas

    if len(mesh.faces) > max_faces:
        mesh = decimate(mesh, max_faces)
    vmapping, faces, uv = xatlas.parametrize(mesh.vertices.astype(np.float32),
                                             mesh.faces.astype(np.uint32))
    return Mesh(mesh.vertices[vmapping.astype(np.int64)], faces.astype(np.int64),
                uv.astype(np.float64))


def decimate(mesh: Mesh, max_faces: int) -> Mesh:
    import open3d as o3d

    o3d_mesh = o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(mesh.vertices),
                                         o3d.utility.Vector3iVector(mesh.faces.astype(np.int32)))
    small = o3d_mesh.simplify_quadric_decimation(target_number_of_triangles=max_faces)
    small.remove_unreferenced_vertices()
    return Mesh(np.asarray(small.vertices), np.asarray(small.triangles))


def rasterize(mesh: Mesh, size: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Texels whose centre lies in a triangle of the UV layout: their (row, col), the
    triangle, and the barycentric coordinates of the centre in it. The layout is ray-cast as
    a flat mesh (open3d, as ``render`` casts the scene): one ray per texel centre."""
    import open3d as o3d

    flat = np.column_stack([mesh.uv * size, np.zeros(len(mesh.uv))]).astype(np.float32)
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.core.Tensor(flat), o3d.core.Tensor(mesh.faces.astype(np.uint32)))
    rows, cols = np.mgrid[0:size, 0:size]
    u, v = cols.ravel() + 0.5, size - (rows.ravel() + 0.5)  # rows run down, v up
    rays = np.column_stack([u, v, np.ones_like(u), np.zeros_like(u), np.zeros_like(u),
                            -np.ones_like(u)]).astype(np.float32)
    hit = scene.cast_rays(o3d.core.Tensor(rays))
    inside = np.isfinite(hit["t_hit"].numpy())
    face = hit["primitive_ids"].numpy()[inside].astype(np.int64)
    st = hit["primitive_uvs"].numpy()[inside].astype(np.float64)  # weights of corners 1, 2
    bary = np.column_stack([1.0 - st.sum(axis=1), st])
    return np.column_stack([rows.ravel()[inside], cols.ravel()[inside]]), face, bary


def sample_views(world: np.ndarray, normal: np.ndarray, capture: Capture,
                 labels: tuple[int, list[np.ndarray]] | None,
                 options: BakeOptions) -> tuple[np.ndarray, np.ndarray]:
    """Each point's colour (uint8 RGB) from the view that sees it best, and whether any did."""
    best = np.full(len(world), -np.inf)
    colour = np.zeros((len(world), 3), dtype=np.uint8)
    for k, frame in enumerate(capture.frames):
        to_camera = frame.world_to_camera()
        cam = world @ to_camera[:3, :3].T + to_camera[:3, 3]
        pixels, z = frame.camera.project(cam)
        col = np.floor(pixels[:, 0]).astype(np.int64)
        row = np.floor(pixels[:, 1]).astype(np.int64)
        height, width = frame.depth.shape
        ok = (z > 1e-6) & (col >= 0) & (col < width) & (row >= 0) & (row < height)
        idx = np.flatnonzero(ok)
        measured = frame.depth[row[idx], col[idx]]
        tolerance = options.depth_tolerance + options.depth_tolerance_relative * z[idx]
        visible = (measured > 0) & (np.abs(measured - z[idx]) < tolerance)
        if labels is not None:
            label, images = labels
            visible &= images[k][row[idx], col[idx]] == label
        idx = idx[visible]
        towards = frame.camera_to_world[:3, 3] - world[idx]
        distance = np.linalg.norm(towards, axis=1)
        facing = np.abs(np.einsum("nd,nd->n", normal[idx], towards)) / np.maximum(distance, 1e-9)
        score = facing / np.maximum(distance, 1e-3)
        better = (facing >= options.min_facing) & (score > best[idx])
        idx, score = idx[better], score[better]
        best[idx] = score
        colour[idx] = frame.rgb[row[idx], col[idx]]
    return colour, np.isfinite(best)


def fill(texels: np.ndarray, colour: np.ndarray, seen: np.ndarray, size: int) -> np.ndarray:
    """The atlas image: seen texels their colour, every other texel (unseen surface, the
    gutter between charts) the colour of the nearest seen one."""
    from scipy.ndimage import distance_transform_edt

    image = np.zeros((size, size, 3), dtype=np.uint8)
    known = np.zeros((size, size), dtype=bool)
    image[texels[seen, 0], texels[seen, 1]] = colour[seen]
    known[texels[seen, 0], texels[seen, 1]] = True
    _, (rows, cols) = distance_transform_edt(~known, return_indices=True)
    return image[rows, cols]


def png(image: np.ndarray) -> bytes:
    from PIL import Image

    buffer = io.BytesIO()
    Image.fromarray(image).save(buffer, format="PNG", optimize=True)
    return buffer.getvalue()
