"""Errors inside Blender are reported in the UI and leave the scene exactly as it was."""

from __future__ import annotations

import json
import shutil

import pytest
from test_export_check import export
from test_import_pose import import_rig, rig_objects

from conftest import addon_module, scene_snapshot


@pytest.fixture
def busy_scene(blender, generated):
    """A scene with the user's own object and one rig already in it."""
    cube = blender.data.objects.new("users_cube", blender.data.meshes.new("users_cube"))
    blender.context.scene.collection.objects.link(cube)
    import_rig(blender, generated["laptop"]["json"])
    return blender


def import_fails(bpy, path, *fragments):
    before = scene_snapshot(bpy)
    with pytest.raises(RuntimeError) as info:
        bpy.ops.import_scene.real2code(filepath=str(path))
    message = str(info.value)
    assert "Import failed, scene unchanged" in message
    for fragment in fragments:
        assert fragment in message, message
    assert scene_snapshot(bpy) == before


def test_malformed_object_json(busy_scene, tmp_path):
    path = tmp_path / "object.json"
    path.write_text('{"schema": "real2code_export/object", \n "parts": [')
    import_fails(busy_scene, path, str(path), "malformed JSON", ":2")


def test_missing_mesh(busy_scene, generated, tmp_path):
    src = generated["box"]["json"].parent
    copy = tmp_path / "box"
    shutil.copytree(src, copy)
    data = json.loads((copy / "object.json").read_text())
    missing = copy / data["parts"][1]["visual"]
    missing.unlink()
    import_fails(busy_scene, copy / "object.json", "mesh file not found", missing.name,
                 f"part {data['parts'][1]['name']!r}")


def test_broken_urdf(busy_scene, generated, tmp_path):
    urdf = generated["table"]["urdf"]
    copy = tmp_path / urdf.name
    shutil.copytree(urdf.parent / "meshes", tmp_path / "meshes")
    copy.write_text(urdf.read_text().replace("<joint ", "<joint type=", 1))
    import_fails(busy_scene, copy, str(copy))


def test_unknown_file_type(busy_scene, tmp_path):
    path = tmp_path / "object.stl"
    path.write_text("solid x\nendsolid x\n")
    import_fails(busy_scene, path, "unknown file type '.stl'")


def test_failure_while_building_removes_everything(busy_scene, generated, monkeypatch):
    """A failure after Blender data was made (here: the third joint Empty) removes it all."""
    to_blender = addon_module("to_blender")
    real = to_blender._joint_empty
    calls = []

    def failing(*args, **kwargs):
        calls.append(1)
        if len(calls) == 3:
            raise RuntimeError("simulated failure inside Blender")
        return real(*args, **kwargs)

    monkeypatch.setattr(to_blender, "_joint_empty", failing)
    import_fails(busy_scene, generated["storage_furniture"]["json"], "simulated failure")
    assert len(calls) == 3


def test_multi_file_import_is_all_or_nothing(busy_scene, generated, tmp_path):
    """The first file imports, the second fails: the first rig is removed again."""
    shutil.copytree(generated["box"]["json"].parent, tmp_path / "box")
    (tmp_path / "bad.json").write_text("{}")
    before = scene_snapshot(busy_scene)
    with pytest.raises(RuntimeError, match="not a real2code_export object"):
        busy_scene.ops.import_scene.real2code(
            directory=str(tmp_path), files=[{"name": "box/object.json"}, {"name": "bad.json"}])
    assert scene_snapshot(busy_scene) == before


def test_invalid_edit_is_reported_and_nothing_written(blender, generated, tmp_path):
    root = import_rig(blender, generated["refrigerator"]["json"])
    rp = addon_module("rig_props")
    je = next(iter(rig_objects(root, rp.ROLE_JOINT).values()))
    je[rp.LOWER] = 2.0
    je[rp.UPPER] = 1.0
    out = tmp_path / "out"
    with pytest.raises(RuntimeError, match=r"Export failed, nothing written: .*lower limit 2.0 > "
                                           r"upper limit 1.0"):
        export(blender, root, out)
    assert not out.exists()
