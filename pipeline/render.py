"""A synthetic posed RGB-D capture of any articulated object, on the CPU.

open3d's ``RaycastingScene`` casts one ray per pixel through the part meshes (placed at a
configuration), which gives the z-depth, the hit part (the ground-truth mask) and the face
normal. RGB is plain Lambert shading of the part colours under a head light and a fixed
key light, in sRGB. Cameras follow a path that knows nothing of the joints
(:mod:`pipeline.camera_paths`: a full ring by default, half rings, hand-held paths, near or
far), look at the object's centre and keep the whole object in view.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from real2code_export.errors import InputError
from real2code_export.kinematics import world_part_meshes
from real2code_export.model import ArticulatedObject, Mesh

from .camera_paths import DEFAULT_DISTANCE, DEFAULT_PATH, camera_path
from .camera_paths import look_at as look_at  # where callers have imported it from
from .capture import Camera, Capture, Frame

DEFAULT_VIEWS = 12  # as the paper
DEFAULT_SIZE = 256
DEFAULT_FOV_DEG = 50.0
BACKGROUND = (0.05, 0.05, 0.06)  # dark, so light parts stand out
KEY_LIGHT = np.array([0.4, -0.3, 0.87])  # world direction towards the light (from above)


@dataclass(frozen=True)
class Lighting:
    ambient: float = 0.3
    head: float = 0.45  # light at the camera
    key: float = 0.35  # fixed light from above


def default_camera(width: int = DEFAULT_SIZE, height: int = DEFAULT_SIZE,
                   fov_deg: float = DEFAULT_FOV_DEG) -> Camera:
    """A pinhole camera with ``fov_deg`` across the shorter image side."""
    f = 0.5 * min(width, height) / np.tan(np.radians(fov_deg) / 2)
    return Camera(f, f, width / 2, height / 2, width, height)


def front_direction(obj: ArticulatedObject, base: np.ndarray | None = None) -> np.ndarray:
    """The horizontal world direction the object opens towards: where its movable parts
    moved from closed (q = 0) to the observed state; the model's +x when nothing moved."""
    base = np.eye(4) if base is None else base
    closed = world_part_meshes(obj, {}, base)
    seen = world_part_meshes(obj, None, base)
    shift = sum((seen[n].vertices.mean(0) - closed[n].vertices.mean(0) for n in seen),
                np.zeros(3))
    shift[2] = 0.0
    if np.linalg.norm(shift) < 1e-6:
        shift = base[:3, 0].copy()
        shift[2] = 0.0
    return shift / np.linalg.norm(shift)


def _srgb(linear: np.ndarray) -> np.ndarray:
    linear = np.clip(linear, 0.0, 1.0)
    return np.where(linear <= 0.0031308, 12.92 * linear,
                    1.055 * np.power(linear, 1 / 2.4) - 0.055)


def background_rgb8(background=BACKGROUND) -> np.ndarray:
    """The 8-bit sRGB colour a render gives a pixel where no ray hits (the mask network's
    training views have it around the object)."""
    return np.round(_srgb(np.asarray(background, np.float64)) * 255).astype(np.uint8)


class Raycaster:
    """Part meshes in one open3d scene; ``render`` gives RGB, z-depth and part ids."""

    def __init__(self, meshes: list[Mesh], colors: list[tuple], scenery: list | None = None):
        """``meshes`` are the parts (mask k for the k-th); ``scenery``
        (:class:`pipeline.room.Scenery`) is seen, never a part (mask 0)."""
        import open3d as o3d

        self.scene = o3d.t.geometry.RaycastingScene()
        self.ids = []
        self.n_parts = len(meshes)
        meshes = [*meshes, *(s.mesh for s in scenery or [])]
        colors = [*colors, *(s.color for s in scenery or [])]
        for mesh in meshes:
            gid = self.scene.add_triangles(
                o3d.core.Tensor(mesh.vertices.astype(np.float32)),
                o3d.core.Tensor(mesh.faces.astype(np.uint32)))
            self.ids.append(gid)
        self.albedo = np.array([c[:3] for c in colors] + [BACKGROUND], dtype=np.float32)

    def render(self, camera: Camera, camera_to_world: np.ndarray,
               lighting: Lighting = Lighting(), background=BACKGROUND,
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """RGB (uint8), z-depth (float32 m, 0 = miss) and mask (uint16: 0 = background,
        k = the k-th mesh) for one view."""
        import open3d as o3d

        dirs_cam = camera.pixel_directions()
        dirs = dirs_cam @ camera_to_world[:3, :3].T
        origin = np.broadcast_to(camera_to_world[:3, 3], dirs.shape)
        rays = np.concatenate([origin, dirs], axis=-1).astype(np.float32)
        hit = self.scene.cast_rays(o3d.core.Tensor(rays))
        t = hit["t_hit"].numpy()
        geometry = hit["geometry_ids"].numpy()
        valid = np.isfinite(t)
        lookup = np.full(max(self.ids, default=0) + 2, -1, dtype=np.int64)
        lookup[np.array(self.ids, dtype=np.int64)] = np.arange(len(self.ids))
        part = np.where(valid, lookup[np.where(valid, geometry, len(lookup) - 1)], -1)
        depth = np.where(valid, t, 0.0).astype(np.float32)  # directions have z = -1
        normals = hit["primitive_normals"].numpy()
        view = -dirs / np.linalg.norm(dirs, axis=-1, keepdims=True)
        facing = np.sign(np.sum(normals * view, axis=-1, keepdims=True))
        normals = normals * np.where(facing == 0, 1.0, facing)  # light both sides of a face
        key = KEY_LIGHT / np.linalg.norm(KEY_LIGHT)
        shade = (lighting.ambient + lighting.head * np.abs(np.sum(normals * view, axis=-1))
                 + lighting.key * np.clip(normals @ key, 0.0, None))
        albedo = self.albedo[np.where(part >= 0, part, len(self.albedo) - 1)]
        linear = albedo * shade[..., None]
        linear[~valid] = background
        rgb = np.round(_srgb(linear) * 255).astype(np.uint8)
        mask = np.where((part >= 0) & (part < self.n_parts), part + 1, 0).astype(np.uint16)
        return rgb, depth, mask


def render_object(obj: ArticulatedObject, *, q: dict[str, float] | None = None,
                  base: np.ndarray | None = None, views: int = DEFAULT_VIEWS,
                  width: int = DEFAULT_SIZE, height: int = DEFAULT_SIZE,
                  fov_deg: float = DEFAULT_FOV_DEG, seed: int = 0,
                  cameras: str = DEFAULT_PATH, distance: str = DEFAULT_DISTANCE,
                  colors: dict[str, tuple] | None = None,
                  lighting: Lighting = Lighting(), background=BACKGROUND,
                  room: bool = False) -> Capture:
    """A capture of ``obj`` at ``q`` (default: its observed state) placed at ``base``.

    ``cameras`` names the camera path and ``distance`` how far it stands
    (:mod:`pipeline.camera_paths`); only ``front-arc`` reads the ground-truth joints.
    ``colors`` overrides part colours (linear RGB(A)) by part name. ``room`` stands the
    object on a floor before a wall, with clutter around (:mod:`pipeline.room`; the same
    cameras as without). The capture's parts are
    the parts with a visual mesh, in the object's order; its ``extra`` records the state
    and pose the object was rendered at.
    """
    if views < 1:
        raise InputError(f"need at least one view, got {views}")
    rng = np.random.default_rng(seed)
    base = np.eye(4) if base is None else np.asarray(base, float)
    config = obj.observed_configuration() if q is None else dict(q)
    meshes = world_part_meshes(obj, config, base)
    names = [p.name for p in obj.parts if p.name in meshes]
    if not names:
        raise InputError(f"object {obj.name!r} has no visual meshes to render")
    palette = {p.name: p.color for p in obj.parts} | (colors or {})
    points = np.concatenate([meshes[n].vertices for n in names])
    lo, hi = points.min(0), points.max(0)
    center = 0.5 * (lo + hi)
    radius = float(np.linalg.norm(points - center, axis=1).max())
    camera = default_camera(width, height, fov_deg)
    front = None
    if cameras == "front-arc":  # the only path that reads the joints: where parts open
        probe = obj
        if q is not None:  # the front is where the parts open at the rendered configuration
            import copy

            probe = copy.deepcopy(obj)
            for j in probe.movable_joints:
                j.state = config.get(j.name, 0.0)
        front = front_direction(probe, base)
    frames = []
    poses = camera_path(cameras, center, radius, camera, views, rng, distance=distance,
                        front=front)
    scenery = []
    if room:
        from .room import room_scenery

        scenery = room_scenery(lo, hi, np.array([p[:3, 3] for p in poses]), rng)
    caster = Raycaster([meshes[n] for n in names], [palette[n] for n in names], scenery)
    for k, pose in enumerate(poses):
        rgb, depth, mask = caster.render(camera, pose, lighting, background)
        frames.append(Frame(camera, pose, rgb, depth, mask, f"frame_{k:05d}"))
    extra = {"object": obj.name, "state": {j: float(v) for j, v in config.items()},
             "object_pose": np.round(base, 12).tolist(), "renderer": "open3d raycasting",
             "seed": int(seed), "camera_path": cameras, "camera_distance": distance,
             "room": [s.name for s in scenery]}
    return Capture(frames, names, extra)


def render_model(model: str | Path, out: str | Path, *, views: int = DEFAULT_VIEWS,
                 width: int = DEFAULT_SIZE, height: int = DEFAULT_SIZE, state: str = "observed",
                 seed: int = 0, cameras: str = DEFAULT_PATH,
                 distance: str = DEFAULT_DISTANCE, sensor: str | Path = "clean",
                 room: bool = False) -> Capture:
    """``real2code render``: load any importable model, render it at its observed state (or,
    with ``state="random"``, every joint partly open, drawn from ``seed``) and write the
    capture folder with the ground-truth object (parts joined by fixed joints merged, as
    the masks see them; its states set to the rendered ones). ``sensor``: a capture preset
    or sensor JSON (:mod:`pipeline.sensors`) whose faults the frames then get; ``room``:
    the object in a room (:mod:`pipeline.room`)."""
    import copy

    from real2code_export.formats import load
    from real2code_export.simplify import merge_fixed_joints

    from .capture import GROUND_TRUTH_DIR, write_capture
    from .predictors.data import ajar_configuration

    if state not in ("observed", "random"):
        raise InputError(f"state must be 'observed' or 'random', got {state!r}")
    # One rigid part per mask: parts welded by fixed joints are one part.
    obj = copy.deepcopy(merge_fixed_joints(load(model)))
    if state == "random":
        q = ajar_configuration(obj, np.random.default_rng(seed))
        for j in obj.movable_joints:
            j.state = q[j.name]
    from .sensors import degrade, load_sensor

    model_of_sensor = load_sensor(sensor)  # a bad preset fails before the rendering
    capture = render_object(obj, views=views, width=width, height=height, seed=seed,
                            cameras=cameras, distance=distance, room=room)
    capture = degrade(capture, model_of_sensor, seed)
    capture.extra["source"] = str(model)
    capture.extra["ground_truth"] = f"{GROUND_TRUTH_DIR}/object.json"
    write_capture(capture, out, ground_truth=obj)
    capture.path = Path(out)
    return capture
