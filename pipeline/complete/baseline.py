"""The "segment only" baseline: a mesh from the part's raw points, no learned completion.

Real2Code's Table 2 column "Real2Code-SegOnly" meshes the segmented point cloud directly.
We use open3d's **alpha shape** (the boundary of the union of Delaunay simplices whose
circumradius is under alpha): it needs no normals, which a partial fused cloud does not give
reliably (a panel seen from both sides has no consistent outside), it never invents surface
away from the points, and its one parameter follows the point spacing. Poisson needs
oriented normals and balloons over unseen sides; ball pivoting leaves the mesh full of holes
at this density. ``method`` keeps both for comparison (see docs/reconstruction.md).
"""

from __future__ import annotations

import numpy as np

from .learned import CompletionError

VOXEL = 0.005  # m: the cloud is thinned to this spacing first (fused views overlap a lot)
VOXELS_PER_DIAGONAL = 250  # ...or coarser for big parts, so a fridge body takes seconds
# Alpha as a multiple of the mean nearest-neighbour spacing: 8 gave the lowest mean part CD
# on 29 training-seed procedural parts seen by the ray caster of ``views.py`` (x1000:
# 4 -> 3.49, 8 -> 2.66, 16 -> 5.37) ...
ALPHA_SPACINGS = 8.0
# ... but the clouds that ``reconstruct`` fuses from a capture (``fuse.part_clouds``: exact
# depth, voxelised coarser) want a larger one: on the parts of 12 procedural dev objects
# rendered as captures, 8 -> 3.21, 12 -> 2.45, 16 -> 2.07, 24 -> 2.36. Each baseline gets the
# alpha that suits its input, so completion is compared with the best of the baseline.
ALPHA_SPACINGS_FUSED = 16.0
METHODS = ("alpha", "ball_pivoting", "poisson")


def _cloud(points: np.ndarray):
    import open3d as o3d

    pts = np.asarray(points, dtype=float)
    if pts.ndim != 2 or pts.shape[1] != 3 or not np.all(np.isfinite(pts)):
        raise CompletionError(f"part points: expected finite (N, 3) points, got shape {pts.shape}")
    if len(pts) < 4:
        raise CompletionError(f"part points: {len(pts)} points, at least 4 needed for a surface")
    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(pts))
    diagonal = float(np.linalg.norm(pts.max(axis=0) - pts.min(axis=0)))
    return pcd.voxel_down_sample(max(VOXEL, diagonal / VOXELS_PER_DIAGONAL))


def _spacing(pcd) -> float:
    return float(np.mean(np.asarray(pcd.compute_nearest_neighbor_distance())))


def _thickened_if_flat(pcd, spacing: float):
    """A cloud whose points all lie on one plane (a table top seen from above, a thin panel
    voxelised to one layer) has no 3D Delaunay triangulation, so Qhull refuses it. Its
    surface is the patch itself: a copy shifted half a spacing along the plane's normal makes
    the alpha shape a slab that thin around the patch. Other clouds are returned unchanged."""
    import open3d as o3d

    pts = np.asarray(pcd.points)
    centred = pts - pts.mean(axis=0)
    _, sv, vt = np.linalg.svd(centred, full_matrices=False)
    thickness = sv[2] / np.sqrt(len(pts))  # RMS distance to the best plane
    if thickness > 0.05 * spacing:
        return pcd
    shifted = pts + 0.5 * spacing * vt[2]
    return o3d.geometry.PointCloud(o3d.utility.Vector3dVector(np.vstack([pts, shifted])))


def _oriented_normals(pcd, spacing: float) -> None:
    import open3d as o3d

    pcd.estimate_normals(o3d.geometry.KDTreeSearchParamHybrid(radius=4 * spacing, max_nn=30))
    pcd.orient_normals_consistent_tangent_plane(10)


def segment_only_mesh(points, method: str = "alpha", alpha_spacings: float = ALPHA_SPACINGS):
    """A triangle mesh (``trimesh.Trimesh``, world frame) of the part's raw ``points``."""
    import open3d as o3d
    import trimesh

    if method not in METHODS:
        raise CompletionError(f"segment-only: unknown method {method!r}; choose from {METHODS}")
    pcd = _cloud(points)
    spacing = _spacing(pcd)
    if method == "alpha":
        # Qhull's flat tetrahedra on planar patches make open3d warn once per tetrahedron.
        with o3d.utility.VerbosityContextManager(o3d.utility.VerbosityLevel.Error):
            try:
                mesh = o3d.geometry.TriangleMesh.create_from_point_cloud_alpha_shape(
                    _thickened_if_flat(pcd, spacing), alpha_spacings * spacing)
            except RuntimeError as e:  # Qhull's precision errors (e.g. all points on a line)
                raise CompletionError(f"segment-only (alpha): {len(pcd.points)} points "
                                      f"admit no 3D triangulation: {str(e)[:120]}") from e
    elif method == "ball_pivoting":
        _oriented_normals(pcd, spacing)
        radii = o3d.utility.DoubleVector([1.5 * spacing, 3 * spacing, 6 * spacing])
        mesh = o3d.geometry.TriangleMesh.create_from_point_cloud_ball_pivoting(pcd, radii)
    else:
        _oriented_normals(pcd, spacing)
        mesh, _ = o3d.geometry.TriangleMesh.create_from_point_cloud_poisson(pcd, depth=8)
    out = trimesh.Trimesh(np.asarray(mesh.vertices), np.asarray(mesh.triangles), process=True)
    if len(out.faces) == 0:
        raise CompletionError(f"segment-only ({method}): no surface from {len(pcd.points)} "
                              "points (too few or all on a line)")
    return out
