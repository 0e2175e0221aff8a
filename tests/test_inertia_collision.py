"""Mass properties against closed forms and trimesh; collision pieces compiled in MuJoCo."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import trimesh

from real2code_export import collision
from real2code_export import transforms as tf
from real2code_export.collision import collision_pieces, convex_hull, is_convex
from real2code_export.errors import Real2CodeWarning
from real2code_export.inertia import (
    box_inertial,
    combine_inertials,
    inertial_from_mesh,
    inertial_from_meshes,
)
from real2code_export.model import Mesh, validate_inertial
from real2code_export.repairs import TRIANGLE_MARGIN

from conftest import partnet_objects


# -- helpers -----------------------------------------------------------------------------------
def box_mesh(extents, center=(0, 0, 0), rotation=None) -> Mesh:
    tm = trimesh.creation.box(extents)
    transform = tf.make(rotation=rotation, translation=center) if rotation is not None else \
        tf.make(translation=center)
    tm.apply_transform(transform)
    return Mesh.from_trimesh(tm)


def l_shape(size: float = 0.1, subdivisions: int = 2) -> Mesh:
    """A closed L-shaped prism (non-convex), 20 * 4**subdivisions faces."""
    xy = np.array([[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2.0]]) * size / 2
    n = len(xy)
    v = np.concatenate([np.column_stack([xy, np.zeros(n)]),
                        np.column_stack([xy, np.full(n, size / 2)])])
    # the L is star-shaped from vertex 0, so a fan triangulates the caps
    f = [[0, k + 1, k] for k in range(1, n - 1)] + [[n, n + k, n + k + 1] for k in range(1, n - 1)]
    for k in range(n):
        j = (k + 1) % n
        f += [[k, j, n + j], [k, n + j, n + k]]
    tm = trimesh.Trimesh(v, np.array(f), process=True)
    for _ in range(subdivisions):
        tm = trimesh.Trimesh(*trimesh.remesh.subdivide(tm.vertices, tm.faces))
    trimesh.repair.fix_normals(tm)
    assert tm.is_volume
    return Mesh.from_trimesh(tm)


def compile_in_mujoco(meshes: list[Mesh]):
    """Every mesh as a geom of one free body, compiled by MuJoCo (which hulls each mesh and
    integrates its inertia, failing on flat or degenerate ones)."""
    import mujoco

    spec = mujoco.MjSpec()
    body = spec.worldbody.add_body(name="body")
    body.add_freejoint()
    for k, m in enumerate(meshes):
        spec.add_mesh(name=f"mesh{k}", uservert=m.vertices.ravel().tolist(),
                      userface=m.faces.ravel().tolist())
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_MESH, meshname=f"mesh{k}")
    return spec.compile()


def plate(extents, center, density) -> tuple[float, np.ndarray, np.ndarray]:
    """Closed-form thin rectangular plate: ``extents`` with one zero (the normal axis)."""
    e = np.asarray(extents, float)
    m = density * np.prod(e[e > 0])
    inertia = m / 12 * np.diag([e[1] ** 2 + e[2] ** 2, e[0] ** 2 + e[2] ** 2, e[0] ** 2 + e[1] ** 2])
    return m, np.asarray(center, float), inertia


def assert_convex_solid(mesh: Mesh) -> None:
    tm = mesh.to_trimesh()
    assert tm.is_volume and tm.is_convex and tm.volume > 0


# -- solids ------------------------------------------------------------------------------------
def test_solid_box_matches_closed_form():
    rot = tf.axis_angle_matrix(np.array([1.0, 2.0, 3.0]) / np.sqrt(14), 0.7)
    ext, center, rho = np.array([0.4, 0.3, 0.2]), np.array([1.0, -2.0, 0.5]), 700.0
    got = inertial_from_mesh(box_mesh(ext, center, rot), rho)
    m = rho * ext.prod()
    expected = rot @ (m / 12 * np.diag([ext[1] ** 2 + ext[2] ** 2, ext[0] ** 2 + ext[2] ** 2,
                                        ext[0] ** 2 + ext[1] ** 2])) @ rot.T
    assert got.mass == pytest.approx(m, rel=1e-9)
    np.testing.assert_allclose(got.com, center, atol=1e-12)
    np.testing.assert_allclose(got.inertia, expected, atol=1e-12 * m)
    ref = box_inertial(ext, density=rho, center=center, rotation=rot)
    assert ref.mass == pytest.approx(m)
    np.testing.assert_allclose(ref.inertia, expected, atol=1e-12 * m)
    validate_inertial(got, "box")


def test_inverted_box_is_repaired_to_the_same_solid():
    mesh = box_mesh([0.4, 0.3, 0.2])
    inverted = Mesh(mesh.vertices, mesh.faces[:, ::-1])
    a, b = inertial_from_mesh(mesh), inertial_from_mesh(inverted)
    assert b.mass == pytest.approx(a.mass) and b.mass > 0
    np.testing.assert_allclose(b.inertia, a.inertia, atol=1e-12)


def test_solid_cylinder_matches_closed_form():
    r, h, rho = 0.1, 0.5, 1000.0
    mesh = Mesh.from_trimesh(trimesh.creation.cylinder(radius=r, height=h, sections=256))
    got = inertial_from_mesh(mesh, rho)
    m = rho * np.pi * r**2 * h
    assert got.mass == pytest.approx(m, rel=1e-3)  # a 256-gon is 1e-4 short of a circle
    np.testing.assert_allclose(got.com, 0, atol=1e-12)
    np.testing.assert_allclose(np.diag(got.inertia),
                               [m * (3 * r**2 + h**2) / 12] * 2 + [m * r**2 / 2], rtol=2e-3)


# -- shells ------------------------------------------------------------------------------------
def test_open_box_is_a_shell_matching_closed_form():
    a, b, c, rho, t = 0.6, 0.4, 0.3, 600.0, 0.01
    tm = trimesh.creation.box([a, b, c])
    top = tm.triangles_center[:, 2] > c / 2 - 1e-9
    mesh = Mesh(tm.vertices, tm.faces[~top])
    got = inertial_from_mesh(mesh, rho, shell_thickness=t)

    sigma = rho * t
    plates = [plate([a, b, 0], [0, 0, -c / 2], sigma)]
    plates += [plate([a, 0, c], [0, s * b / 2, 0], sigma) for s in (-1, 1)]
    plates += [plate([0, b, c], [s * a / 2, 0, 0], sigma) for s in (-1, 1)]
    mass = sum(p[0] for p in plates)
    com = sum(p[0] * p[1] for p in plates) / mass
    inertia = sum(p[2] + p[0] * (np.dot(p[1] - com, p[1] - com) * np.eye(3)
                                 - np.outer(p[1] - com, p[1] - com)) for p in plates)
    assert got.mass == pytest.approx(mass, rel=1e-12)
    np.testing.assert_allclose(got.com, com, atol=1e-12)
    np.testing.assert_allclose(got.inertia, inertia, atol=1e-12 * mass)
    validate_inertial(got, "open box")


def test_flat_square_gives_a_valid_inertial():
    side, rho, t = 0.5, 500.0, 0.005
    square = Mesh([[0, 0, 0], [side, 0, 0], [side, side, 0], [0, side, 0]], [[0, 1, 2], [0, 2, 3]])
    got = inertial_from_mesh(square, rho, shell_thickness=t)
    validate_inertial(got, "flat square")
    m = rho * t * side**2
    assert got.mass == pytest.approx(m)
    moments = np.linalg.eigvalsh(got.inertia)
    # the in-plane moments keep a margin over A + B = C (repairs.TRIANGLE_MARGIN of the
    # largest, split between them), which MuJoCo's import of a rotated tensor needs
    in_plane = m * side**2 / 12 * (1 + TRIANGLE_MARGIN)
    np.testing.assert_allclose(moments, [in_plane] * 2 + [m * side**2 / 6], rtol=1e-9)


def test_zero_area_mesh_falls_back_to_a_thin_box_with_a_warning():
    line = Mesh([[0, 0, 0], [0.5, 0, 0], [1, 0, 0]], [[0, 1, 2]])
    with pytest.warns(Real2CodeWarning, match="no area or volume"):
        got = inertial_from_mesh(line)
    validate_inertial(got, "line")
    np.testing.assert_allclose(got.com, [0.5, 0, 0], atol=1e-12)


def test_sliver_shell_is_clamped_to_positive_definite():
    # a long thin strip made of nearly collinear triangles: the smallest moment is ~0
    strip = Mesh([[0, 0, 0], [1, 0, 0], [1, 1e-6, 0], [0, 1e-6, 0]], [[0, 1, 2], [0, 2, 3]])
    with warnings.catch_warnings():
        warnings.simplefilter("error", Real2CodeWarning)  # the shell path, not the fallback
        got = inertial_from_mesh(strip)
    validate_inertial(got, "strip")
    assert np.linalg.eigvalsh(got.inertia)[0] > 0


def test_mixed_closed_and_open_components_sum_solid_and_shell():
    closed = box_mesh([0.2, 0.2, 0.2], [1, 0, 0])
    square = Mesh([[0, 0, 0], [0.5, 0, 0], [0.5, 0.5, 0], [0, 0.5, 0]], [[0, 1, 2], [0, 2, 3]])
    both = inertial_from_mesh(Mesh.concatenate([closed, square]))
    parts = inertial_from_meshes([closed, square])
    expected = combine_inertials([(inertial_from_mesh(closed), np.eye(4)),
                                  (inertial_from_mesh(square), np.eye(4))])
    for got in (both, parts):
        assert got.mass == pytest.approx(500 * 0.008 + 500 * 0.005 * 0.25)
        np.testing.assert_allclose(got.com, expected.com, atol=1e-12)
        # (the flat square alone keeps its margin over A + B = C: TRIANGLE_MARGIN of its
        # largest moment, 5e-8 kg m^2; the sum is no flat panel and needs none)
        np.testing.assert_allclose(got.inertia, expected.inertia, atol=1e-7)


def _topology_cases() -> dict[str, trimesh.Trimesh]:
    box = trimesh.creation.box((0.1, 0.2, 0.3))
    inverted = trimesh.Trimesh(box.vertices, box.faces[:, ::-1], process=False)
    scrambled = box.faces.copy()
    scrambled[::3] = scrambled[::3, ::-1]
    sphere = trimesh.creation.icosphere(2, radius=0.05).apply_translation((0.3, 0, 0))
    hollow = trimesh.util.concatenate([trimesh.creation.box((0.2, 0.2, 0.2)),
                                       trimesh.creation.box((0.1, 0.1, 0.1))])
    hollow.faces[12:] = hollow.faces[12:, ::-1]  # the inner box wound inward: a cavity
    cap = trimesh.creation.icosphere(1)
    cap = cap.submesh([np.flatnonzero(cap.triangles_center[:, 2] > 0)], append=True)
    sheet = trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2], [0, 2, 1]])
    return {
        "box": box, "inverted": inverted,
        "scrambled": trimesh.Trimesh(box.vertices, scrambled, process=False),
        "two bodies, one scrambled": trimesh.util.concatenate(
            [trimesh.Trimesh(box.vertices, scrambled, process=False), sphere]),
        "hollow": hollow, "open cap and a box": trimesh.util.concatenate(
            [cap, box.copy().apply_translation((3, 3, 3))]),
        "two-sided sheet": sheet,
        "cylinder off the origin": trimesh.creation.cylinder(0.03, 0.2, sections=40)
        .apply_translation((1, 2, 3)),
    }


@pytest.mark.parametrize("case", list(_topology_cases()))
def test_numpy_topology_and_mass_properties_match_trimesh(case):
    """meshtopology and the integrals stand in for trimesh (whose import costs more than an
    export): the same closed/open decisions and the same figures as the trimesh-based code."""
    from real2code_export import inertia, meshtopology

    tm = _topology_cases()[case]
    processed = trimesh.Trimesh(tm.vertices, tm.faces, process=True)
    vertices, faces = meshtopology.merged(np.asarray(tm.vertices), np.asarray(tm.faces))
    edges = meshtopology.Edges(faces)
    assert len(vertices) == len(processed.vertices)
    assert edges.watertight() == processed.is_watertight
    assert edges.winding_consistent() == (processed.is_watertight
                                          and processed.is_winding_consistent)
    labels = meshtopology.component_labels(len(faces), edges.face_adjacency())
    expected = trimesh.graph.connected_component_labels(processed.face_adjacency,
                                                        node_count=len(processed.faces))
    np.testing.assert_array_equal(labels, expected)
    mesh = Mesh(np.asarray(tm.vertices), np.asarray(tm.faces))
    got = inertia._inertial_of_pieces([mesh], 500.0, 0.005)
    solid = processed.copy()
    if processed.is_watertight and not processed.is_volume:
        trimesh.repair.fix_winding(solid)
        trimesh.repair.fix_inversion(solid, multibody=True)
    if solid.is_volume:  # the whole mesh a solid: trimesh's own integration is the reference
        solid.density = 500.0
        assert got.mass == pytest.approx(solid.mass, rel=1e-9)
        np.testing.assert_allclose(got.com, solid.center_mass, atol=1e-12)
        np.testing.assert_allclose(got.inertia, solid.moment_inertia, rtol=1e-9,
                                   atol=1e-9 * np.abs(solid.moment_inertia).max())
    else:
        assert got.mass > 0
        validate_inertial(got, case)


# -- combining ---------------------------------------------------------------------------------
def test_combine_matches_trimesh_on_a_union():
    rng = np.random.default_rng(3)
    boxes = [([0.3, 0.2, 0.1], [0, 0, 0]), ([0.1, 0.4, 0.2], [0.5, 0.1, -0.2]),
             ([0.2, 0.2, 0.2], [-0.4, 0.3, 0.3])]
    items, world_meshes = [], []
    for ext, center in boxes:
        local = box_mesh(ext)
        axis = rng.normal(size=3)
        rotation = tf.axis_angle_matrix(axis / np.linalg.norm(axis), rng.uniform(-np.pi, np.pi))
        pose = tf.make(rotation=rotation, translation=center)
        items.append((inertial_from_mesh(local, 800.0), pose))
        world_meshes.append(local.transformed(pose))
    union = Mesh.concatenate(world_meshes).to_trimesh()  # disjoint boxes: union = concatenation
    assert union.is_volume
    union.density = 800.0
    combined = combine_inertials(items)
    from_pieces = inertial_from_meshes(world_meshes, 800.0)
    for got in (combined, from_pieces):
        assert got.mass == pytest.approx(union.mass, rel=1e-9)
        np.testing.assert_allclose(got.com, union.center_mass, atol=1e-12)
        np.testing.assert_allclose(got.inertia, union.moment_inertia, atol=1e-10)
        validate_inertial(got, "union")


# -- convex hulls ------------------------------------------------------------------------------
def test_hull_of_coplanar_points_compiles_in_mujoco_where_the_raw_mesh_does_not():
    square = Mesh([[0, 0, 0], [0.3, 0, 0], [0.3, 0.2, 0], [0, 0.2, 0]], [[0, 1, 2], [0, 2, 3]])
    with pytest.raises(ValueError, match="coplanar"):
        compile_in_mujoco([square])
    hull = convex_hull(square, min_thickness=1e-3)
    assert_convex_solid(hull)
    np.testing.assert_allclose(np.ptp(hull.vertices, axis=0), [0.3, 0.2, 1e-3], atol=1e-12)
    model = compile_in_mujoco([hull])
    assert model.nmesh == 1 and model.body_mass[1] > 0


def test_hull_of_collinear_and_single_points_compiles_in_mujoco():
    line = Mesh([[0, 0, 0], [0.1, 0.1, 0.1], [0.2, 0.2, 0.2]], [[0, 1, 2]])
    point = Mesh([[0.1, 0.2, 0.3]], np.zeros((0, 3)))
    hulls = [convex_hull(line), convex_hull(point)]
    for h in hulls:
        assert_convex_solid(h)
    compile_in_mujoco(hulls)


def test_hull_of_a_closed_box_is_the_box():
    box = box_mesh([0.3, 0.2, 0.1], [1, 2, 3])
    hull = convex_hull(box)
    assert hull.to_trimesh().volume == pytest.approx(0.006)
    assert is_convex(box)
    assert not is_convex(l_shape())


# -- collision pieces --------------------------------------------------------------------------
def test_hull_and_auto_on_a_convex_mesh_give_one_piece():
    box = box_mesh([0.3, 0.2, 0.1])
    for method in ("hull", "auto"):
        (piece,) = collision_pieces(box, method)
        assert piece.to_trimesh().volume == pytest.approx(0.006)


def test_pieces_mode_drops_duplicates_and_contained_pieces():
    a = box_mesh([0.2, 0.2, 0.2], [0, 0, 0])
    b = box_mesh([0.2, 0.2, 0.2], [1, 0, 0])
    inside = box_mesh([0.05, 0.05, 0.05], [1, 0, 0])
    flat = Mesh([[0, 2, 0], [0.4, 2, 0], [0.4, 2.4, 0]], [[0, 1, 2]])
    sources = [b, a, inside, a, flat]
    pieces = collision_pieces(Mesh.concatenate(sources), "auto", source_pieces=sources)
    assert len(pieces) == 3
    for p in pieces:
        assert_convex_solid(p)
    centroids = np.array([p.vertices.mean(axis=0) for p in pieces])
    assert [tuple(c) for c in centroids] == sorted(tuple(c) for c in centroids)
    compile_in_mujoco(pieces)


def test_pieces_mode_caps_the_count_and_covers_every_source_vertex():
    sources = [box_mesh([0.1, 0.1, 0.1], [0.15 * k, 0.02 * k, 0]) for k in range(10)]
    pieces = collision_pieces(Mesh.concatenate(sources), "pieces", source_pieces=sources,
                              max_pieces=3)
    assert len(pieces) == 3
    all_vertices = np.concatenate([s.vertices for s in sources])
    depth = np.min([collision._depth_inside(collision._hull_planes(p.to_trimesh()), all_vertices)
                    for p in pieces], axis=0)
    assert depth.max() < 1e-9  # every source vertex is inside some piece


def test_pieces_mode_merges_a_tiny_piece_into_its_neighbour():
    big = box_mesh([1.0, 1.0, 0.2], [0, 0, 0])
    screw = box_mesh([0.01, 0.01, 0.02], [0.3, 0.3, 0.105])  # on the top face
    far = box_mesh([0.01, 0.01, 0.01], [3, 3, 3])  # tiny but far away: kept on its own
    pieces = collision_pieces(big, "pieces", source_pieces=[big, screw, far])
    assert len(pieces) == 2
    near, isolated = pieces  # sorted by centroid
    assert near.vertices[:, 2].max() == pytest.approx(0.115)  # the screw is in the big hull
    assert np.ptp(isolated.vertices, axis=0) == pytest.approx([0.01] * 3)


def test_pieces_mode_without_sources_splits_connected_components():
    mesh = Mesh.concatenate([box_mesh([0.1] * 3, [0, 0, 0]), box_mesh([0.1] * 3, [1, 0, 0])])
    assert len(collision_pieces(mesh, "pieces")) == 2


def test_pieces_output_is_deterministic():
    rng = np.random.default_rng(0)
    sources = [box_mesh(rng.uniform(0.05, 0.2, 3), rng.uniform(-1, 1, 3)) for _ in range(12)]
    runs = [collision_pieces(Mesh.concatenate(sources), "pieces", source_pieces=s, max_pieces=5)
            for s in (sources, sources[::-1])]
    assert [p.digest() for p in runs[0]] == [p.digest() for p in runs[1]]


def test_unknown_method_is_refused():
    with pytest.raises(ValueError, match="unknown collision method"):
        collision_pieces(box_mesh([1, 1, 1]), "vhacd")


# -- coacd (one tiny real run; the rest is served from the cache or mocked) ---------------------
@pytest.fixture(scope="module")
def coacd_run(tmp_path_factory):
    cache = tmp_path_factory.mktemp("coacd_cache")
    mesh = l_shape()
    return mesh, cache, collision_pieces(mesh, "coacd", cache_dir=cache)


def _fail(*args, **kwargs):
    raise RuntimeError("coacd must not be called")


def test_coacd_decomposes_a_non_convex_mesh(coacd_run):
    mesh, cache, pieces = coacd_run
    assert len(pieces) >= 2  # one hull could not be right
    for p in pieces:
        assert_convex_solid(p)
    volume = sum(p.to_trimesh().volume for p in pieces)
    assert volume == pytest.approx(mesh.to_trimesh().volume, rel=0.1)
    assert volume < 0.9 * convex_hull(mesh).to_trimesh().volume
    compile_in_mujoco(pieces)
    assert len(list(cache.glob("*.npz"))) == 1


def test_coacd_cache_is_hit_the_second_time(coacd_run, monkeypatch):
    mesh, cache, pieces = coacd_run
    monkeypatch.setattr(collision, "_run_coacd", _fail)
    with warnings.catch_warnings():
        warnings.simplefilter("error", Real2CodeWarning)  # no fallback happened
        again = collision_pieces(mesh, "coacd", cache_dir=cache)
    assert [p.digest() for p in again] == [p.digest() for p in pieces]


def test_corrupt_cache_entry_is_ignored_and_recomputed(coacd_run, tmp_path, monkeypatch):
    mesh, _, pieces = coacd_run
    calls = []
    monkeypatch.setattr(collision, "_run_coacd",
                        lambda m, t, n: calls.append(1) or [box_mesh([0.1] * 3), box_mesh([0.1] * 3, [1, 0, 0])])
    collision_pieces(mesh, "coacd", cache_dir=tmp_path)
    (entry,) = tmp_path.glob("*.npz")
    entry.write_bytes(b"not an npz file")
    with pytest.warns(Real2CodeWarning, match="unreadable collision cache"):
        again = collision_pieces(mesh, "coacd", cache_dir=tmp_path)
    assert len(calls) == 2 and len(again) == 2
    assert collision._read_cache(entry) is not None  # rewritten


def test_coacd_failure_falls_back_to_one_hull(tmp_path, monkeypatch):
    monkeypatch.setattr(collision, "_run_coacd", _fail)
    with pytest.warns(Real2CodeWarning, match="CoACD decomposition failed"):
        pieces = collision_pieces(l_shape(subdivisions=0), "coacd", cache_dir=tmp_path)
    assert len(pieces) == 1
    assert_convex_solid(pieces[0])
    assert not list(tmp_path.glob("*.npz"))  # a fallback is not cached


def test_cache_dir_follows_the_environment(monkeypatch, tmp_path):
    monkeypatch.setenv("REAL2CODE_CACHE", str(tmp_path))
    assert collision.default_cache_dir() == tmp_path / "coacd"


# -- real PartNet-Mobility pieces --------------------------------------------------------------
def _partnet_links(obj_dir):
    """(link name, [pieces]) from a mobility.urdf (each piece in its own OBJ frame; the
    URDF origins are translations shared by the link's pieces, irrelevant to hulls)."""
    from lxml import etree

    from real2code_export.meshfiles import read_mesh

    tree = etree.parse(str(obj_dir / "mobility.urdf"))
    for link in tree.iter("link"):
        files = sorted({m.get("filename") for m in link.iterfind("visual/geometry/mesh")})
        if files:
            yield link.get("name"), [read_mesh(obj_dir / f) for f in files]


def test_partnet_pieces_hull_and_compile_in_mujoco():
    objects = partnet_objects("dev")[:2]
    n_links = 0
    for obj_dir in objects:
        for name, pieces in _partnet_links(obj_dir):
            hulls = [convex_hull(p) for p in pieces]
            merged = collision_pieces(Mesh.concatenate(pieces), "auto", source_pieces=pieces)
            for h in hulls + merged:
                assert_convex_solid(h)
            model = compile_in_mujoco(hulls + merged)
            assert model.nmesh == len(hulls) + len(merged)
            validate_inertial(inertial_from_meshes(pieces), f"{obj_dir.name}/{name}")
            n_links += 1
    assert n_links >= 2


def test_coacd_is_deterministic_across_fresh_caches(coacd_run, tmp_path):
    mesh, _, pieces = coacd_run
    again = collision_pieces(mesh, "coacd", cache_dir=tmp_path)
    assert [p.digest() for p in again] == [p.digest() for p in pieces]


def test_auto_keeps_the_inside_of_an_open_box(monkeypatch):
    """A drawer (a box without its top) must keep its inside: its hull would fill it."""
    monkeypatch.setattr(collision, "_run_coacd", _fail)
    tm = trimesh.creation.box([0.4, 0.3, 0.2])
    open_box = Mesh(tm.vertices, tm.faces[tm.triangles_center[:, 2] < 0.1 - 1e-9])
    pieces = collision_pieces(open_box, "auto")
    assert len(pieces) >= 5  # bottom and four walls
    for p in pieces:
        assert_convex_solid(p)
    assert sum(p.to_trimesh().volume for p in pieces) < 0.25 * 0.024
    inside = np.array([[0.0, 0.0, 0.0], [0.1, 0.05, 0.05], [-0.1, -0.1, 0.09]])
    for p in pieces:
        assert not p.to_trimesh().contains(inside).any()
    compile_in_mujoco(pieces)


def test_boxes_keep_a_solid_as_its_hull():
    (piece,) = collision_pieces(box_mesh([0.4, 0.3, 0.2]), "boxes")
    assert piece.to_trimesh().volume == pytest.approx(0.024)


def test_pieces_mode_on_a_triangle_soup_falls_back_to_one_hull():
    rng = np.random.default_rng(1)
    soup = Mesh(rng.uniform(0, 1, (3 * 300, 3)), np.arange(3 * 300).reshape(-1, 3))
    with pytest.warns(Real2CodeWarning, match="loose components"):
        (piece,) = collision_pieces(soup, "pieces")
    assert_convex_solid(piece)


@pytest.mark.parametrize("dtype", [np.int32, np.int64, np.uint16])
def test_stable_argsort_is_numpys_stable_sort(dtype):
    """meshtopology.stable_argsort: numpy's stable permutation (ties in input order), by the
    tagged quick sort where key and position fit an int64 and by the stable sort where not."""
    from real2code_export.meshtopology import stable_argsort

    rng = np.random.default_rng(3)
    for keys in (rng.integers(0, 50, 10_000), np.repeat(np.arange(7)[::-1], 300),
                 np.arange(1000), np.zeros(5), np.array([4]), np.zeros(0)):
        keys = keys.astype(dtype)
        np.testing.assert_array_equal(stable_argsort(keys), np.argsort(keys, kind="stable"))
    wide = np.array([2**62, -(2**62), 5, 5, -(2**62), 2**62], dtype=np.int64)  # no room
    np.testing.assert_array_equal(stable_argsort(wide), np.argsort(wide, kind="stable"))
    negative = rng.integers(-(2**40), 2**40, 5000)
    negative[::7] = negative[0]
    np.testing.assert_array_equal(stable_argsort(negative), np.argsort(negative, kind="stable"))


@pytest.mark.parametrize("dtype", [np.int32, np.int64, np.uint32])
def test_unique_inverse_is_numpys_unique(dtype):
    """meshtopology.unique_inverse: np.unique's values (their dtype too) and inverse, where
    the keys are counted (a span under twice their number) and where they are sorted."""
    from real2code_export.meshtopology import unique_inverse

    rng = np.random.default_rng(5)
    for keys in (rng.integers(0, 900, 1000), rng.integers(7, 10, 50),  # counted
                 rng.integers(0, 10**6, 1000), np.array([3, 10**9, 3]),  # sorted
                 np.array([4]), np.zeros(0, dtype=np.int64)):
        keys = keys.astype(dtype)
        got, inverse = unique_inverse(keys)
        want, want_inverse = np.unique(keys, return_inverse=True)
        assert got.dtype == want.dtype
        np.testing.assert_array_equal(got, want)
        np.testing.assert_array_equal(inverse, want_inverse.reshape(-1))
