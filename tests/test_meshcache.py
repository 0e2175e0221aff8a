"""Reading OBJ files once (geometry and MTL colour, tinyobjloader) and the disk cache of what
is derived from meshes (hulls, mass properties)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from real2code_export import meshcache
from real2code_export.collision import collision_pieces
from real2code_export.errors import FormatError, Real2CodeWarning, warn
from real2code_export.inertia import inertial_from_meshes
from real2code_export.meshfiles import obj_bytes, read_mesh, read_mesh_file
from real2code_export.model import Mesh

CUBE = """mtllib cube.mtl
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
v 0 0 1
v 1 0 1
v 1 1 1
v 0 1 1
v 5 5 5
usemtl red
f 1 4 3 2
f 5 6 7 8
usemtl blue
f 1 2 6 5
f 2 3 7 6
f 3 4 8 7
f 4 1 5 8
"""


def _cube(tmp_path, mtl: str | None = "newmtl red\nKd 1 0 0\nnewmtl blue\nKd 0 0 1\n"):
    (tmp_path / "cube.obj").write_text(CUBE)
    if mtl is not None:
        (tmp_path / "cube.mtl").write_text(mtl)
    return tmp_path / "cube.obj"


def test_obj_geometry_and_mtl_colour_in_one_read(tmp_path):
    read = read_mesh_file(_cube(tmp_path))
    mesh, color, texture, runs = read.mesh, read.color, read.texture, read.runs
    assert texture is None  # its MTL names no image
    assert mesh.vertices.shape == (8, 3)  # the unused vertex 9 is dropped, as trimesh does
    assert mesh.faces.shape == (12, 3)  # quads fanned into triangles
    assert np.isclose(abs(mesh.to_trimesh().volume), 1.0)
    # two faces red, four blue, all of area 1: weighted by area; and each triangle's own
    assert np.allclose(color, (1 / 3, 0.0, 2 / 3, 1.0))
    assert runs == ((4, (1.0, 0.0, 0.0, 1.0)), (8, (0.0, 0.0, 1.0, 1.0)))


def test_obj_without_its_mtl_has_no_colour_and_a_broken_obj_is_an_error(tmp_path):
    assert read_mesh_file(_cube(tmp_path, mtl=None)).color is None
    bad = tmp_path / "bad.obj"
    bad.write_text("v 0 0 0\nv 1 0 0\nf 1 2 7\n")
    with pytest.raises(FormatError, match="bad.obj"):
        read_mesh(bad)
    empty = tmp_path / "empty.obj"
    empty.write_text("v 0 0 0\n")
    with pytest.raises(FormatError, match="no triangles"):
        read_mesh(empty)


def test_obj_numbers_read_back_exactly(tmp_path):
    rng = np.random.default_rng(0)
    mesh = Mesh(rng.normal(size=(30, 3)) / 7.0, rng.integers(0, 30, size=(40, 3)))
    path = tmp_path / "exact.obj"
    path.write_bytes(obj_bytes(mesh, exact=True))
    back = read_mesh(path)
    assert np.array_equal(back.vertices, mesh.vertices[np.unique(mesh.faces)])


def test_a_mesh_file_read_again_is_parsed_once_with_its_warnings(tmp_path, monkeypatch):
    from real2code_export import meshfiles

    parsed = []
    parse = meshfiles._read_unscaled
    monkeypatch.setattr(meshfiles, "_read_unscaled", lambda *a: parsed.append(1) or parse(*a))
    path = _cube(tmp_path, mtl="newmtl red\nKd 1 0 0\nmap_Kd gone.png\n")
    first = read_mesh_file(path)
    with pytest.warns(Real2CodeWarning, match="gone.png"):  # said again on every read
        again = read_mesh_file(path, scale=[2.0, 1.0, 1.0])
    assert len(parsed) == 1 and again.color == first.color
    assert np.array_equal(again.mesh.vertices, first.mesh.vertices * [2.0, 1.0, 1.0])
    with pytest.raises(ValueError, match="read-only"):  # one reader cannot change another's
        first.mesh.vertices[0, 0] = 9.0
    # the file changed in place, its size the same: read again; so when its MTL changes
    path.write_text(CUBE.replace("v 1 1 1", "v 1 1 2"))
    assert read_mesh(path).vertices[:, 2].max() == 2.0 and len(parsed) == 2
    (tmp_path / "cube.mtl").write_text("newmtl red\nKd 0 1 0\n")
    assert read_mesh_file(path).color[:3] == (0.0, 1.0, 0.0) and len(parsed) == 3


def test_stl_files_read_ahead_on_threads_are_read_once_and_the_same(tmp_path, monkeypatch):
    """``read_ahead`` parses a model's STL files on two threads into the meshes read lately:
    ``read_mesh_file`` then parses none of them again and gets what it would have read
    itself; a broken file is left to it, which names the file and element."""
    import trimesh

    from real2code_export import meshfiles

    for k, extents in enumerate([(1, 2, 3), (0.2, 0.1, 0.4), (3, 3, 1)]):
        trimesh.creation.box(extents=extents).export(tmp_path / f"box{k}.stl")
    (tmp_path / "broken.stl").write_bytes(b"solid nothing here\n")
    paths = [tmp_path / f"box{k}.stl" for k in range(3)] + [tmp_path / "broken.stl"]
    alone = [meshfiles._read_stl(p, p.read_bytes(), None, None, None) for p in paths[:3]]
    meshfiles._READ.entries.clear()
    meshfiles._READ.used = 0
    meshfiles.read_ahead(paths)
    parsed = []
    parse = meshfiles._read_unscaled
    monkeypatch.setattr(meshfiles, "_read_unscaled", lambda *a: parsed.append(a[0]) or parse(*a))
    for path, mesh in zip(paths[:3], alone, strict=True):
        read = read_mesh(path)
        assert np.array_equal(read.vertices, mesh.vertices)
        assert np.array_equal(read.faces, mesh.faces)
    assert parsed == []
    with pytest.raises(FormatError, match=r"robot\.xml: <mesh name='b'>: mesh .*broken\.stl"):
        read_mesh(paths[3], source="robot.xml", element="<mesh name='b'>")
    assert parsed == [paths[3]]


def test_stl_files_read_ahead_are_read_from_disk_once(tmp_path, monkeypatch):
    """The keys ``read_ahead`` returns find its meshes without the files being read and
    hashed again; a key whose mesh is gone (or a file read ahead alone) is read as before."""
    import pathlib

    import trimesh

    from real2code_export import meshfiles

    for k, extents in enumerate([(1, 2, 3), (0.2, 0.1, 0.4)]):
        trimesh.creation.box(extents=extents).export(tmp_path / f"box{k}.stl")
    paths = [tmp_path / f"box{k}.stl" for k in range(2)]
    meshfiles._READ.entries.clear()
    meshfiles._READ.used = 0
    keys = meshfiles.read_ahead(paths)
    assert set(keys) == set(paths)
    reads = []
    read_bytes = pathlib.Path.read_bytes
    monkeypatch.setattr(pathlib.Path, "read_bytes", lambda p: reads.append(p) or read_bytes(p))
    got = [read_mesh(p, key=keys[p]) for p in paths]
    assert reads == [] and [len(m.faces) for m in got] == [12, 12]
    meshfiles._READ.entries.clear()
    meshfiles._READ.used = 0
    assert np.array_equal(read_mesh(paths[0], key=keys[paths[0]]).faces, got[0].faces)
    assert reads == [paths[0]]


def test_cache_returns_the_stored_result_and_keeps_warnings(tmp_path, monkeypatch):
    monkeypatch.setenv("REAL2CODE_CACHE", str(tmp_path / "cache"))
    mesh = Mesh(np.eye(3), [[0, 1, 2]])
    calls = []

    def compute():
        calls.append(1)
        return [mesh]

    args = ("test", [mesh], {"p": 1}, compute, meshcache.encode_meshes, meshcache.decode_meshes)
    first = meshcache.cached(*args)
    again = meshcache.cached(*args)
    assert len(calls) == 1 and np.array_equal(again[0].vertices, first[0].vertices)
    meshcache.cached("test", [mesh], {"p": 2}, compute, meshcache.encode_meshes,
                     meshcache.decode_meshes)
    assert len(calls) == 2  # other parameters, another entry

    def warned():
        warn("repaired something")
        return [mesh]

    for _ in range(2):  # never stored, so the warning comes every time
        with pytest.warns(Real2CodeWarning, match="repaired something"):
            meshcache.cached("warned", [mesh], {}, warned, meshcache.encode_meshes,
                             meshcache.decode_meshes)
    # an unreadable entry is recomputed
    for entry in (tmp_path / "cache" / "test").iterdir():
        entry.write_bytes(b"not a zip")
    meshcache.cached(*args)
    assert len(calls) == 3
    monkeypatch.setenv("REAL2CODE_CACHE", "off")
    meshcache.cached(*args)
    meshcache.cached(*args)
    assert len(calls) == 5
    from real2code_export.collision import default_cache_dir

    assert default_cache_dir() is None  # nor CoACD's decompositions


def test_cached_hulls_and_inertials_equal_fresh_ones(tmp_path, monkeypatch):
    monkeypatch.setenv("REAL2CODE_CACHE", str(tmp_path / "cache"))
    cube = read_mesh(_cube(tmp_path))
    pieces = [cube, Mesh(cube.vertices + [2.0, 0, 0], cube.faces)]
    with warnings.catch_warnings():
        warnings.simplefilter("error", Real2CodeWarning)
        fresh = collision_pieces(Mesh.concatenate(pieces), "pieces", source_pieces=pieces)
        stored = collision_pieces(Mesh.concatenate(pieces), "pieces", source_pieces=pieces)
        inertial = inertial_from_meshes(pieces)
        again = inertial_from_meshes(pieces)
    assert len(list((tmp_path / "cache" / "pieces").iterdir())) == 1
    assert len(list((tmp_path / "cache" / "inertial").iterdir())) == 1
    assert all(np.array_equal(a.vertices, b.vertices) and np.array_equal(a.faces, b.faces)
               for a, b in zip(fresh, stored, strict=True))
    assert again.mass == inertial.mass and np.array_equal(again.inertia, inertial.inertia)
    assert np.isclose(inertial.mass, 2 * 500.0)  # two closed unit cubes at 500 kg/m^3
