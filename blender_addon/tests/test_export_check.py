"""Export from Blender to every format, then check the files: the full ``real2code check`` of
the main venv (MuJoCo, Pinocchio, UsdPhysics, glTF reader and Khronos validator), and the
partial check inside Blender when no real2code command is configured."""

from __future__ import annotations

import json
import os
import re

import pytest
from test_import_pose import import_rig

from conftest import REAL2CODE, addon_module, main_venv, partnet_urdf, run_main

ALL = {"json", "mjcf", "urdf", "usd", "gltf"}


def export(bpy, root, out, formats=ALL, check=True):
    bpy.context.view_layer.objects.active = root
    return bpy.ops.export_scene.real2code(directory=str(out), formats=formats, run_check=check)


def outcome(root):
    rp = addon_module("rig_props")
    return json.loads(root[rp.CHECK])


def test_export_and_full_check(blender, generated, tmp_path):
    main_venv()
    root = import_rig(blender, generated["storage_furniture"]["json"])
    panel = addon_module("panel")
    door = next(ob for ob, _, label in panel.joint_sliders(root) if "door" in label)
    panel.set_joint_value(door, 1.0)  # a pose is not an edit: the export is the same model
    assert export(blender, root, tmp_path) == {"FINISHED"}
    written = sorted(p.name for p in tmp_path.iterdir())
    assert written == sorted(["object.json", "meshes", "storage_furniture_3.glb",
                              "storage_furniture_3.urdf", "storage_furniture_3.usda",
                              "storage_furniture_3.xml"])
    result = outcome(root)
    assert result["ok"], result["mismatches"]
    assert result["how"] == "real2code check"
    labels = " ".join(p["name"] for p in result["probes"])
    for tool in ("MuJoCo", "Pinocchio", "UsdPhysics", "glTF", "model"):
        assert tool in labels, labels
    assert not result["skipped"]
    # the same files pass the command line's check run by hand (exit 0)
    files = [str(p) for p in tmp_path.iterdir() if p.is_file()]
    run_main([str(REAL2CODE), "check", *files, "--configurations", "10"])


@pytest.mark.partnet
def test_partnet_export_and_full_check(blender, tmp_path):
    main_venv()
    root = import_rig(blender, partnet_urdf("45213"))
    assert export(blender, root, tmp_path) == {"FINISHED"}
    result = outcome(root)
    assert result["ok"], result["mismatches"]
    assert len(result["probes"]) == 6  # model, MuJoCo x2, Pinocchio, UsdPhysics, glTF


def test_partial_check_inside_blender(blender, generated, tmp_path, monkeypatch):
    prefs = blender.context.preferences.addons[addon_module("preferences").__package__]
    prefs.preferences.real2code_executable = ""
    monkeypatch.setenv("PATH", os.pathsep.join(
        p for p in os.environ["PATH"].split(os.pathsep) if not (p and os.path.isfile(
            os.path.join(p, "real2code")))))
    root = import_rig(blender, generated["table"]["json"])
    assert export(blender, root, tmp_path) == {"FINISHED"}
    result = outcome(root)
    assert result["ok"], result["mismatches"]
    assert result["how"] == "partial check inside Blender"
    labels = " ".join(p["name"] for p in result["probes"])
    for tool in ("MuJoCo", "glTF", "model"):
        assert tool in labels, labels
    assert "Pinocchio" not in labels
    skipped = " ".join(result["skipped"])
    assert "Pinocchio" in skipped and "Khronos" in skipped
    # Blender 5.0's OpenUSD 25.08 lacks UsdPhysicsLoadStageFromPrimRange, which the project's
    # USD probe calls today: then the USD file is skipped, saying so (see docs/blender.md)
    assert "UsdPhysics" in labels or "does not run on this Blender's OpenUSD" in skipped


def test_check_failure_is_reported(blender, generated, tmp_path):
    """A disagreement (``real2code check`` exits 1) is a failed outcome with its mismatches:
    here the MJCF file is edited after export, a joint axis flipped."""
    main_venv()
    root = import_rig(blender, generated["refrigerator"]["json"])
    assert export(blender, root, tmp_path, check=False) == {"FINISHED"}
    check_run = addon_module("check_run")
    xml = tmp_path / "refrigerator_2.xml"
    text = xml.read_text()
    edited = re.sub(r'(<joint [^>]*axis=")([^"]+)"',
                    lambda m: m.group(1) + " ".join(str(-float(v)) for v in m.group(2).split())
                    + '"', text, count=1)
    assert edited != text
    xml.write_text(edited)
    files = [p for p in tmp_path.iterdir() if p.is_file()]
    result = check_run.run_full(str(REAL2CODE), files, 10)
    assert not result.ok
    assert any("refrigerator_2.xml" in m or "MuJoCo" in m for m in result.mismatches)
