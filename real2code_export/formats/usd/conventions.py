"""What the USD writer and reader agree on: the layout, stage metadata and units (the writer
authors them in ``layer``), opening stages, and the conversions between the model's float64
transforms and USD's value types.

Layout of a file we write (after Newton's urdf-usd-converter asset structure):

    /<object>            Xform, defaultPrim, PhysicsArticulationRootAPI
        Geometry/<part>  Xform, PhysicsRigidBodyAPI + PhysicsMassAPI: visual and collision meshes
        Physics/<joint>  PhysicsRevoluteJoint / PhysicsPrismaticJoint / PhysicsFixedJoint
        Looks/<part>     Material (UsdPreviewSurface)
        MeshAssets/mesh_<k>  (class) a mesh placed by several prims, each an internal
                         reference to it with its own pose (a robot's mesh file used by
                         several geoms, written once)
    /PhysicsScene        outside the asset, so referencing the object never adds a second scene

The mesh arrays are in a binary layer the .usda sublayers, ``meshes/<object>.usdc``
(``geometry.move_mesh_arrays``; docs/formats.md).

Part prims are flat (siblings under Geometry, each placed in the world at q = state): every
USD physics engine accepts flat bodies, while nested rigid bodies are not yet supported
everywhere (urdf-usd-converter docs/concept_mapping.md, "Flat Bodies").

Floats: UsdPhysics stores joint frames, limits and mass properties as 32-bit floats. Every
value we write is chosen so that reading it back and writing it again gives the same float
(see :func:`snapped_quat`), which makes export -> import -> export byte-identical.
"""

from __future__ import annotations

import contextlib
import itertools
import re
import struct
from pathlib import Path

import numpy as np

from ... import transforms as tf
from ...errors import FormatError, InputError

GEOMETRY, PHYSICS, LOOKS = "Geometry", "Physics", "Looks"
# a class (abstract: never drawn, simulated or traversed) of the mesh assets placed by
# several prims, each referring to one (geometry.AssetLibrary)
MESH_ASSETS = "MeshAssets"
SCENE = "PhysicsScene"
NAMESPACE = "real2code"  # our custom attributes: real2code:state, real2code:effort, ...
WORLD_JOINT = "world_fixed"
METADATA = f"{NAMESPACE}:metadata"  # the object's metadata (JSON) on the object prim
FLOATING_JOINT = f"{NAMESPACE}:floatingJoint"  # on a free body: its floating joint's name
FRAME_JOINT = f"{NAMESPACE}:fixedJoint"  # on a frame (an Xform in a body): its joint's name
# on a joint written from the body holding the frame it hangs from (body.in_parent_body):
# that frame's part name
PARENT_PART = f"{NAMESPACE}:parentPart"
# a part's own mass properties where the prim's PhysicsMassAPI states a welded group's (a
# body carrying the parts welded below it) or the prim is no body (those parts' frames):
# mass (kg; 0: the part has none), centre of mass (m, part frame), inertia (kg m^2, about
# the centre of mass: xx yy zz xy xz yz, as newton:inertia)
OWN_MASS = f"{NAMESPACE}:ownMass"
OWN_CENTER_OF_MASS = f"{NAMESPACE}:ownCenterOfMass"
OWN_INERTIA = f"{NAMESPACE}:ownInertia"


def source_name(prim) -> str:
    """A prim's name as its source had it: usd-exchange (NVIDIA's converters, Isaac Sim's
    importers) writes a name that is no valid identifier encoded (``tn__`` + its valid
    characters + a code of the rest: ``tn__leftfoot_YF`` for ``left-foot``) with the name
    itself as the prim's ``displayName``; elsewhere the prim's name."""
    name = prim.GetName()
    if name.startswith("tn__"):
        return prim.GetDisplayName() or name
    return name


# -- opening ---------------------------------------------------------------------------------
_PARSE_ERROR = re.compile(r":(\d+):\d+: (.*?)(?: in <([^>]*)>)?'?$", re.MULTILINE)


# the first OpenUSD release whose UsdPhysics parse is safe on many threads
_PHYSICS_PARSE_THREAD_SAFE = (0, 26, 5)


def load_physics(stage):
    """UsdPhysics' own parse of the whole stage. usd-core 26.11 names it
    ``UsdPhysicsLoadStageFromPrimRange`` (the old ``LoadUsdPhysicsFromRange`` is deprecated);
    OpenUSD 25.08, inside Blender 5.0, has only the old name: take whichever exists."""
    from pxr import Usd, UsdPhysics, Work

    loader = (getattr(UsdPhysics, "UsdPhysicsLoadStageFromPrimRange", None)
              or UsdPhysics.LoadUsdPhysicsFromRange)
    if Usd.GetVersion() >= _PHYSICS_PARSE_THREAD_SAFE:
        return loader(stage, ["/"])
    # Older parsers race when a rigid body holds many colliders and now and then crash the
    # process (newton-physics/newton#1743, #3293: fixed in OpenUSD 26.5; a Blender 5.0
    # add-on test crashed so once in three runs): parse on one thread, then restore.
    limit = Work.GetConcurrencyLimit()
    Work.SetConcurrencyLimit(1)
    try:
        return loader(stage, ["/"])
    finally:
        Work.SetConcurrencyLimit(limit)


def open_stage(path: Path):
    """Open a .usda/.usd/.usdc file; FormatError (with the line for text files) if it cannot.
    Our own schema (NewtonMassAPI, NewtonJointAPI) is registered first, so that files we
    wrote read back with it."""
    from pxr import Tf, Usd

    # (without the package, files still open; the Newton attributes are then left unread)
    with contextlib.suppress(ImportError):
        import newton_usd_schemas  # noqa: F401

    if not path.is_file():
        raise FormatError(path, None, "file not found")
    try:
        stage = Usd.Stage.Open(str(path), Usd.Stage.LoadAll)
    except Tf.ErrorException as e:
        text = str(e)
        m = _PARSE_ERROR.search(text)
        if m:
            element = f"prim <{m.group(3)}>" if m.group(3) else None
            raise FormatError(path, element, f"malformed USD: {m.group(2)}", int(m.group(1))) from e
        raise FormatError(path, None, f"cannot open USD: {text.strip().splitlines()[-1]}") from e
    if stage is None:
        raise FormatError(path, None, "cannot open USD")
    _refuse_missing_sublayers(stage, path)
    return stage


def _refuse_missing_sublayers(stage, path: Path) -> None:
    """A sublayer USD cannot read (our binary mesh layer, moved or deleted) would compose
    into a stage without the prims and values it holds, with only a warning: refused."""
    from pxr import Pcp

    errors = stage.GetCompositionErrors() if hasattr(stage, "GetCompositionErrors") else []
    missing = [e for e in errors if e.errorType == Pcp.ErrorType_InvalidSublayerPath]
    if missing:
        raise FormatError(path, None, f"a layer it sublayers cannot be read: "
                          f"{str(missing[0]).strip().rstrip('.')}")


def stage_units(stage) -> tuple[float, float, np.ndarray]:
    """(metres per unit, kilograms per unit, rotation taking the stage's up axis to +Z)."""
    from pxr import UsdGeom, UsdPhysics

    mpu = float(UsdGeom.GetStageMetersPerUnit(stage))
    kpu = float(UsdPhysics.GetStageKilogramsPerUnit(stage))
    up = np.eye(4)
    if UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.y:
        up[:3, :3] = tf.axis_angle_matrix([1.0, 0.0, 0.0], np.pi / 2)  # +Y -> +Z
    return mpu, kpu, up


# -- value conversions -----------------------------------------------------------------------
_TINY, _FINE = 2.0**-16, 2.0**-40


def _quantised(q: np.ndarray) -> np.ndarray:
    """float32 values; components below 2^-16 on a 2^-40 grid instead, so that float64
    noise (~1e-16) around a component that should be 0 cannot survive as 1e-25."""
    out = np.asarray(q, dtype=np.float32).astype(np.float64)
    small = np.abs(q) < _TINY
    out[small] = np.round(q[small] / _FINE) * _FINE
    return out + 0.0  # no -0.0


def _canonical(q: np.ndarray) -> np.ndarray:
    """q or -q (the same rotation): the first non-zero component positive."""
    first = q[np.flatnonzero(q)[0]]
    return -q + 0.0 if first < 0 else q


def _renormalised(q: np.ndarray) -> np.ndarray:
    return _canonical(_quantised(q / np.linalg.norm(q)))


_FLOAT32 = struct.Struct("<f")


def _quantised_floats(q: list[float]) -> list[float]:
    """:func:`_quantised` of Python floats (a C cast to float each, as numpy's)."""
    return [(round(v / _FINE) * _FINE if abs(v) < _TINY
             else _FLOAT32.unpack(_FLOAT32.pack(v))[0]) + 0.0 for v in q]


def _canonical_floats(q: list[float]) -> list[float]:
    """:func:`_canonical` of Python floats."""
    first = next(v for v in q if v != 0)
    return [-v + 0.0 for v in q] if first < 0 else q


def _neighbour(v: float, step: int) -> float:
    if step == 0:
        return v
    if abs(v) < _TINY:
        return v + step * _FINE
    return float(np.nextafter(np.float32(v), np.float32(step * np.inf)))


def snapped_quat(rotation: np.ndarray) -> np.ndarray:
    """A float32-exact (w, x, y, z) for ``rotation`` that reading back (normalise in float64)
    and writing again reproduces exactly (a fixed point), so re-exporting an imported file
    gives the same bytes. Quantising q usually is one; otherwise iterate, then search the
    one-step neighbourhood for the fixed point nearest to q. Error: ~1e-7 rad, float32's."""
    q = tf.matrix_to_quat(rotation)
    # (the iteration in Python floats: the operations of _quantised, _canonical and
    # _renormalised on the four numbers, the same results, a fifth of the time: every body,
    # joint frame and shape placed has one)
    c = _canonical_floats(_quantised_floats(q.tolist()))
    for _ in range(3):
        norm = tf.short_norm(c)  # what np.linalg.norm computes
        n = _canonical_floats(_quantised_floats([v / norm for v in c]))
        if n == c:
            return np.array(c)
        c = n
    base = _canonical(_quantised(q))
    q = q if float(q @ base) >= 0 else -q
    best, best_err = base, np.inf
    for steps in itertools.product((-1, 0, 1), repeat=4):
        cand = _canonical(np.array([_neighbour(v, k) for v, k in zip(base, steps, strict=True)])
                          + 0.0)
        if np.array_equal(_renormalised(cand), cand):
            err = float(np.abs(cand - (q if float(q @ cand) >= 0 else -q)).max())
            if err < best_err:
                best, best_err = cand, err
    return best


def quatf(rotation: np.ndarray):
    from pxr import Gf

    w, x, y, z = (float(v) for v in snapped_quat(rotation))
    return Gf.Quatf(w, x, y, z)


def rotation_of(quat) -> np.ndarray:
    """3x3 rotation of a Gf quaternion (normalised in float64)."""
    im = quat.GetImaginary()
    q = [float(quat.GetReal()), float(im[0]), float(im[1]), float(im[2])]
    if not np.all(np.isfinite(q)) or np.linalg.norm(q) < 1e-12:
        raise InputError(f"not a rotation quaternion: {q}")
    return tf.quat_to_matrix(q)


def pose(position, quat, scale: float = 1.0) -> np.ndarray:
    """4x4 from a Gf position (scaled to metres) and a Gf quaternion."""
    return tf.make(rotation_of(quat), np.array([float(v) for v in position]) * scale)


def as_float32(value: float) -> float:
    return float(np.float32(value))


def float_outward(value: float, upward: bool) -> float:
    """The float32 nearest to ``value``, moved one ulp outward when rounding went inward by
    more than 1e-12 relative: a limit written this way still contains every value the
    model allowed (the observed state stays inside), and re-rounding an imported limit
    does not move it again."""
    f = np.float32(value)
    inward = (float(f) < value) if upward else (float(f) > value)
    if inward and abs(float(f) - value) > 1e-12 * max(1.0, abs(value)):
        f = np.nextafter(f, np.float32(np.inf if upward else -np.inf))
    return float(f)


def world_transforms(stage, prims) -> dict[str, np.ndarray]:
    """World 4x4 (column vectors, stage units) of each prim, by path string."""
    from pxr import Usd, UsdGeom

    cache = UsdGeom.XformCache(Usd.TimeCode.Default())
    return {str(p.GetPath()): np.array(cache.GetLocalToWorldTransform(p), dtype=float).T
            for p in prims}


def relative_transform(cache, prim, ancestor) -> np.ndarray:
    """4x4 of ``prim`` in the frame of ``ancestor`` (column vectors, stage units)."""
    m, _ = cache.ComputeRelativeTransform(prim, ancestor)
    return np.array(m, dtype=float).T
