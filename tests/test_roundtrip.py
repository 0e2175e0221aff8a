"""The proof of an export: every file loaded in its own tool agrees with the model.

MJCF in MuJoCo, URDF in MuJoCo and in Pinocchio, USD through the UsdPhysics parser and glTF
through a glTF reader are posed at 100 random configurations (plus q = 0 and the observed
state) and every part's world pose is compared with the model's forward kinematics:
1e-6 m and 1e-6 rad. The glTF and USD validators must report no error.
"""

from __future__ import annotations

import pytest

from real2code_export.check import check_files
from real2code_export.formats import export, load

from conftest import partnet_dir, partnet_ids
from helpers import small_cabinet

TOL = 1e-6
GENERATED = [
    ("storage_furniture", 2, 0), ("storage_furniture", 3, 1), ("storage_furniture", 5, 2),
    ("storage_furniture", 9, 3), ("storage_furniture", 15, 4), ("table", None, 5),
    ("table", None, 6), ("refrigerator", None, 7), ("refrigerator", None, 8),
    ("laptop", None, 9), ("box", None, 10),
]


PROBES = {"MuJoCo (MJCF)", "MuJoCo (URDF)", "Pinocchio (URDF)", "USD (UsdPhysics)",
          "glTF (nodes + joint metadata)"}


def _assert_agree(obj, out_dir, formats=("json", "mjcf", "urdf", "usd", "gltf")):
    written = export(obj, out_dir, list(formats))
    report = check_files(list(written.values()), n_configurations=100, seed=1,
                         tol_position=TOL, tol_rotation=TOL)
    assert {p.label for p in report.probes} >= PROBES
    assert report.ok, [m.message for m in report.mismatches]
    assert {v.tool: v.errors for v in report.validations} == {
        "UsdValidation": 0, "Khronos glTF validator": 0}
    for v in report.validations:  # listed in the test output (pytest -rA)
        for message in v.messages:
            print(f"{v.tool} warning: {message}")
    return report


def test_small_cabinet_agrees_everywhere(tmp_path):
    _assert_agree(small_cabinet(), tmp_path)


@pytest.mark.parametrize("category, n_parts, seed", GENERATED)
def test_generated_objects_agree_everywhere(tmp_path, category, n_parts, seed):
    from pipeline.procedural import generate

    obj = generate(category, n_parts, seed)
    if n_parts is not None:
        assert len(obj.parts) == n_parts
    _assert_agree(obj, tmp_path)


@pytest.mark.partnet
@pytest.mark.parametrize("object_id", partnet_ids())
def test_partnet_objects_agree_everywhere(tmp_path, object_id):
    urdf = partnet_dir() / object_id / "mobility.urdf"
    with pytest.warns(Warning):  # real files are repaired, never silently
        obj = load(urdf)
    _assert_agree(obj, tmp_path)
