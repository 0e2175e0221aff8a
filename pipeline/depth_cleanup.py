"""A capture as a real sensor gives it, made fit to fuse: the first reconstruction stage.

Real depth has noise that grows with range, pixels missing alone and in holes, pixels flying
between a silhouette and what lies behind it, and camera poses a little off. Each frame's
depth is cleaned on its own, at the noise level it shows (estimated from the frame, never
told: a clean capture passes through unchanged), then the poses are refined across views:

1. outliers: a pixel far (in the frame's own noise) from the median of its neighbours, or
   with too few neighbours, is dropped: flying pixels and specks;
2. small holes are filled with the median of the pixels around them (a hole a sensor left in
   a surface, not the background: most of its neighbours must agree);
3. noise: each pixel takes the depth of the plane fitted through its neighbours on the same
   surface (those within a few sigma), which keeps edges;
4. poses: every view is registered to the others' fused points (point-to-plane ICP, open3d),
   twice round, and its pose is moved only where that fits better.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .capture import Capture, Frame


@dataclass(frozen=True)
class CleanupOptions:
    outlier_sigmas: float = 4.0  # off the neighbours' median by more: dropped
    min_neighbours: int = 4  # of 8, with depth: fewer is a speck
    fill_rounds: int = 2  # grow fills this many pixels into a hole
    fill_neighbours: int = 5  # of 8 with depth, agreeing, fill a missing pixel (a 2 x 2 hole)
    smooth_radius: int = 3  # (2r + 1)^2 window of the surface fit
    smooth_sigmas: float = 3.0  # neighbours within this of a pixel are its surface
    min_noise_rel: float = 4e-4  # below this relative noise a frame is taken as exact
    icp_rounds: int = 2
    icp_distance: float = 0.02  # of the object's diagonal: ICP's correspondence range


def _neighbourhood(depth: np.ndarray, radius: int) -> np.ndarray:
    """(k, H, W) the depths of every pixel's (2r + 1)^2 - 1 neighbours, NaN where none."""
    h, w = depth.shape
    pad = np.pad(np.where(depth > 0, depth, np.nan), radius, constant_values=np.nan)
    out = [pad[radius + dr:radius + dr + h, radius + dc:radius + dc + w]
           for dr in range(-radius, radius + 1) for dc in range(-radius, radius + 1)
           if dr or dc]
    return np.stack(out)


def noise_level(depth: np.ndarray) -> float:
    """The frame's depth noise relative to depth: a robust spread of each pixel's step from
    its 8 neighbours' median, where all 8 have depth (so not across silhouettes)."""
    near = _neighbourhood(depth, 1)
    full = (depth > 0) & ~np.isnan(near).any(axis=0)
    if full.sum() < 50:
        return 0.0
    with np.errstate(invalid="ignore"):
        residual = (depth[full] - np.median(near[:, full], axis=0)) / depth[full]
    return float(1.4826 * np.median(np.abs(residual)))


def is_noisy(noise_rel: float, options: CleanupOptions = CleanupOptions()) -> bool:
    """Whether a frame of this relative noise is noisy (cleaned) rather than exact (passed
    through): the one test of it, which the later stages read through the capture's summary
    (:func:`measured_noisy`)."""
    return noise_rel >= options.min_noise_rel


def measured_noisy(summary: dict) -> bool:
    """Whether :func:`clean_capture` found any frame of the capture noisy (its summary's
    ``noisy``, taken on the unrounded noise; a summary written before it kept the verdict,
    in a capture saved cleaned, is judged by its frames' noise)."""
    if "noisy" in summary:
        return bool(summary["noisy"])
    return any(is_noisy(n) for n in summary["noise_rel"])


def outliers(depth: np.ndarray, noise: float,
             options: CleanupOptions = CleanupOptions()) -> np.ndarray:
    """Which of a frame's pixels with depth are outliers at its relative ``noise``: far
    from the median of their neighbours, or with too few neighbours (flying pixels between
    a silhouette and what lies behind it, specks)."""
    out = depth.astype(np.float64)
    near = _neighbourhood(out, 1)
    count = (~np.isnan(near)).sum(axis=0)
    with np.errstate(invalid="ignore"), np.errstate(all="ignore"):
        median = np.nanmedian(np.where(count[None] > 0, near, 0.0), axis=0)
    off = np.abs(out - median) > options.outlier_sigmas * noise * np.maximum(out, 1e-6)
    return (out > 0) & ((count < options.min_neighbours) | off)


def clean_depth(depth: np.ndarray, options: CleanupOptions = CleanupOptions(),
                ) -> tuple[np.ndarray, dict]:
    """One frame's depth with outliers dropped, small holes filled and noise smoothed (all
    at the frame's own noise level), and what was done."""
    noise = noise_level(depth)
    if not is_noisy(noise, options):
        return depth, {"noise_rel": noise, "dropped": 0, "filled": 0}
    out = depth.astype(np.float64).copy()
    drop = outliers(out, noise, options)
    out[drop] = 0.0
    filled = 0
    for _ in range(options.fill_rounds):
        near = _neighbourhood(out, 1)
        count = (~np.isnan(near)).sum(axis=0)
        hole = (out == 0) & (count >= options.fill_neighbours)
        if not hole.any():
            break
        values = near[:, hole]
        mid = np.nanmedian(values, axis=0)
        spread = np.nanmax(values, axis=0) - np.nanmin(values, axis=0)
        agree = spread <= 2 * options.smooth_sigmas * noise * mid
        rows, cols = np.nonzero(hole)
        out[rows[agree], cols[agree]] = mid[agree]
        filled += int(agree.sum())
    reference = np.nanmedian(np.concatenate([out[None], _neighbourhood(out, 1)]), axis=0) \
        if (out > 0).any() else out
    out = np.where(out > 0, _surface_fit(out, np.nan_to_num(reference), noise, options), 0.0)
    return out.astype(np.float32), {"noise_rel": noise, "dropped": int(drop.sum()),
                                    "filled": filled}


def _surface_fit(depth: np.ndarray, reference: np.ndarray, noise: float,
                 options: CleanupOptions) -> np.ndarray:
    """Each pixel's depth from the plane through its neighbours on the same surface (those
    within ``smooth_sigmas`` of noise of its neighbourhood's median ``reference``): a
    weighted least-squares fit of inverse depth, which is linear in the pixel coordinates
    on a plane. Edges keep their sharpness (the far side is not the same surface); a pixel
    whose neighbours cannot hold a plane keeps its median."""
    r = options.smooth_radius
    band = options.smooth_sigmas * noise * np.maximum(reference, 1e-6)
    inverse = np.where(depth > 0, 1.0 / np.maximum(depth, 1e-9), 0.0)
    h, w = depth.shape
    pad_d = np.pad(depth, r)
    pad_i = np.pad(inverse, r)
    m = np.zeros((h, w, 3, 3))
    b = np.zeros((h, w, 3))
    for dr in range(-r, r + 1):
        for dc in range(-r, r + 1):
            d = pad_d[r + dr:r + dr + h, r + dc:r + dc + w]
            y = pad_i[r + dr:r + dr + h, r + dc:r + dc + w]
            weight = ((d > 0) & (np.abs(d - reference) <= band)).astype(float)
            x = np.array([1.0, dc, dr])
            m += weight[..., None, None] * np.outer(x, x)
            b += (weight * y)[..., None] * x
    count = m[..., 0, 0]
    ok = count >= 6
    m[~ok] = np.eye(3)
    b[~ok] = 0.0
    m[..., 1, 1] += 1e-3  # a pixel's neighbours on one line hold no plane: keep it solvable
    m[..., 2, 2] += 1e-3
    fitted = np.linalg.solve(m, b[..., None])[..., 0, 0]
    good = ok & (fitted > 0)
    return np.where(good, 1.0 / np.where(good, fitted, 1.0), reference)


def _cloud(frame: Frame, depth: np.ndarray, voxel: float):
    import open3d as o3d

    dirs = frame.camera.pixel_directions()
    cam = (dirs * depth[..., None])[depth > 0]
    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(cam.astype(np.float64)))
    return pcd.voxel_down_sample(voxel)


def refine_poses(frames: list[Frame], diagonal: float,
                 options: CleanupOptions = CleanupOptions()) -> tuple[list[np.ndarray], list]:
    """Every frame's camera-to-world pose registered to the other frames' points (point to
    plane ICP), ``icp_rounds`` times round; a pose moves only when the fit gets better. Also
    how far each camera moved, refined against recorded (not the rounds' steps summed: a
    view's steps go back and forth, and the whole's drift is undone at the end)."""
    import open3d as o3d

    reg = o3d.pipelines.registration
    voxel = diagonal / 150
    local = [_cloud(f, f.depth, voxel) for f in frames]
    for pcd in local:  # normals once per view (each seen from its camera, so they agree when
        # the views' points are merged), not once per merge: the merges' normals took most
        # of the cleanup's time
        pcd.estimate_normals(o3d.geometry.KDTreeSearchParamHybrid(3 * voxel, 30))
        pcd.orient_normals_towards_camera_location(np.zeros(3))
    poses = [f.camera_to_world.copy() for f in frames]
    distance = options.icp_distance * diagonal
    if len(frames) < 2:
        return poses, [0.0] * len(frames)
    for _ in range(options.icp_rounds):
        for k in range(len(frames)):
            others = o3d.geometry.PointCloud()
            for i, pcd in enumerate(local):
                if i != k:
                    others += o3d.geometry.PointCloud(pcd).transform(poses[i])
            others = others.voxel_down_sample(voxel)  # normals averaged per voxel
            if len(others.points) < 50 or len(local[k].points) < 50:
                continue
            others.normalize_normals()
            before = reg.evaluate_registration(local[k], others, distance, poses[k])
            result = reg.registration_icp(  # Tukey: points of a part seen only here
                local[k], others, distance, poses[k],  # do not pull the view
                reg.TransformationEstimationPointToPlane(reg.TukeyLoss(k=distance / 2)),
                reg.ICPConvergenceCriteria(max_iteration=30))
            if result.fitness >= before.fitness and \
                    result.inlier_rmse <= before.inlier_rmse:
                poses[k] = np.asarray(result.transformation)
    poses = _anchored(poses, [f.camera_to_world for f in frames])
    return poses, [float(np.linalg.norm(p[:3, 3] - f.camera_to_world[:3, 3]))
                   for p, f in zip(poses, frames, strict=True)]


def _anchored(refined: list[np.ndarray], recorded: list[np.ndarray]) -> list[np.ndarray]:
    """``refined`` moved as one so that, on average, they agree with the ``recorded`` poses:
    registration fixes the views relative to each other, not where the whole lies, and the
    recorded poses' errors average out."""
    from scipy.spatial.transform import Rotation

    corrections = [r @ np.linalg.inv(p) for r, p in zip(refined, recorded, strict=True)]
    turn = Rotation.from_matrix([c[:3, :3] for c in corrections]).mean().as_matrix()
    centre = np.mean([p[:3, 3] for p in recorded], axis=0)  # turn about the cameras' centre
    shift = np.mean([r[:3, 3] for r in refined], axis=0) - centre
    drift = np.eye(4)
    drift[:3, :3] = turn
    drift[:3, 3] = centre + shift - turn @ centre
    undo = np.linalg.inv(drift)
    return [undo @ r for r in refined]


def clean_capture(capture: Capture, options: CleanupOptions = CleanupOptions(),
                  ) -> tuple[Capture, dict]:
    """``capture`` with every frame's depth cleaned and the poses refined across views (a
    new capture; the frames' images and masks are shared), and a summary of what changed.
    A capture cleaned already (its ``extra`` holds the summary) is returned as it is."""
    from .fuse import object_diagonal

    if "depth_cleanup" in capture.extra:
        return capture, capture.extra["depth_cleanup"]
    depths, notes = [], []
    for frame in capture.frames:
        depth, note = clean_depth(frame.depth, options)
        depths.append(depth)
        notes.append(note)
    cleaned = [Frame(f.camera, f.camera_to_world, f.rgb, d, f.mask, f.name)
               for f, d in zip(capture.frames, depths, strict=True)]
    noisy = any(is_noisy(n["noise_rel"], options) for n in notes)
    moves = [0.0] * len(cleaned)
    if noisy:  # an exact capture's poses are taken as they are
        draft = Capture(cleaned, capture.parts, capture.extra, capture.path)
        poses, moves = refine_poses(cleaned, object_diagonal(draft), options)
        cleaned = [Frame(f.camera, p, f.rgb, f.depth, f.mask, f.name)
                   for f, p in zip(cleaned, poses, strict=True)]
    summary = {"noise_rel": [round(n["noise_rel"], 5) for n in notes],
               "dropped": sum(n["dropped"] for n in notes),
               "filled": sum(n["filled"] for n in notes),
               "pose_moves_m": [round(m, 4) for m in moves], "noisy": noisy,
               "min_noise_rel": options.min_noise_rel}
    extra = dict(capture.extra) | {"depth_cleanup": summary}
    return Capture(cleaned, list(capture.parts), extra, capture.path), summary
