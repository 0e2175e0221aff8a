"""A textured object through the rig: the image packed into the .blend as it was, the UV map
on the mesh, the material showing it; an unedited rig exports the same pixels and UVs."""

from __future__ import annotations

import numpy as np
from test_export_check import export
from test_import_pose import import_rig, rig_objects

from conftest import REPO, addon_module, main_venv, run_main

MAKE = """
import sys
sys.path.insert(0, sys.argv[1])
from test_textures import textured_cabinet
from real2code_export.formats import export
export(textured_cabinet(), sys.argv[2], ["json"])
"""


def test_texture_through_the_rig(blender, tmp_path):
    from real2code_export.formats import load
    from real2code_export.model import differences

    python = main_venv() / "python"
    run_main([str(python), "-c", MAKE, str(REPO / "tests"), str(tmp_path / "in")])
    original = load(tmp_path / "in" / "object.json")
    root = import_rig(blender, tmp_path / "in" / "object.json")
    rp = addon_module("rig_props")
    door = rig_objects(root, rp.ROLE_PART)["door"]
    assert door.data.uv_layers.active is not None
    nodes = door.active_material.node_tree.nodes
    image = next(n for n in nodes if n.type == "TEX_IMAGE").image
    assert bytes(image.packed_file.data) == original.part("door").texture.image
    assert rig_objects(root, rp.ROLE_PART)["body"].data.uv_layers.active is None
    assert export(blender, root, tmp_path / "out", formats={"json"}, check=False) == {"FINISHED"}
    back = load(tmp_path / "out" / "object.json")
    assert differences(original, back, tol=1e-6) == []
    assert back.part("door").texture.image == original.part("door").texture.image
    assert np.abs(back.part("door").visual.uv - original.part("door").visual.uv).max() < 1e-6


MAKE_PBR = """
import sys
sys.path.insert(0, sys.argv[1])
from test_textures import pbr_cabinet
from real2code_export.formats import export
export(pbr_cabinet(), sys.argv[2], ["json"])
"""


def test_material_maps_through_the_rig(blender, tmp_path):
    """Metallic-roughness, normal, occlusion and emissive maps wired as Blender's glTF importer
    wires them, and exported back byte for byte from an unedited rig."""
    from real2code_export.formats import load
    from real2code_export.model import PBR_MAPS, differences

    python = main_venv() / "python"
    run_main([str(python), "-c", MAKE_PBR, str(REPO / "tests"), str(tmp_path / "in")])
    original = load(tmp_path / "in" / "object.json")
    root = import_rig(blender, tmp_path / "in" / "object.json")
    rp = addon_module("rig_props")
    material = rig_objects(root, rp.ROLE_PART)["door"].active_material
    bsdf = next(n for n in material.node_tree.nodes if n.type == "BSDF_PRINCIPLED")
    wired = {name: bsdf.inputs[name].links[0].from_node.type
             for name in ("Base Color", "Roughness", "Metallic", "Normal", "Emission Color")}
    assert wired == {"Base Color": "TEX_IMAGE", "Roughness": "SEPARATE_COLOR",
                     "Metallic": "SEPARATE_COLOR", "Normal": "NORMAL_MAP",
                     "Emission Color": "TEX_IMAGE"}
    assert any(n.type == "GROUP" and "Occlusion" in n.inputs for n in material.node_tree.nodes)
    assert export(blender, root, tmp_path / "out", formats={"json"}, check=False) == {"FINISHED"}
    back = load(tmp_path / "out" / "object.json")
    assert sorted(back.part("door").maps) == sorted(PBR_MAPS)
    assert differences(original, back, tol=1e-6) == []
