"""Every URDF of example-robot-data, every MuJoCo Menagerie model in ../shared/data and every
URDF and MJCF file pybullet ships (pybullet_data, less its generated random_urdfs), to all four
formats, each export checked against its SOURCE file loaded in its own tools
(kinematics to 1e-6 m / rad at 100 configurations), the USD passing UsdValidation, and its
dynamics read back equal (masses,
inertias, damping, friction, armature, limits: the model's tolerance); and the source's own
dynamics as its tools build it equal the export's in the same tools
(:mod:`real2code_export.probes.dynamics`): an MJCF source's and the MJCF export's in MuJoCo;
a URDF source's and the URDF export's in Pinocchio, and the source as MuJoCo imports it (where
MuJoCo loads it as it is) against the MJCF export; a difference is a repair when a reader's
warning names its element and says what of it changed (``dynamics.explaining``), any other
fails.

Files are converted in a process pool (one worker per core) as the session starts; each test
waits for its own file. Files that do not convert are listed in REFUSED with the reason they
are refused for (also in docs/corpora.md, from ``bench/corpus_survey.py``): the test fails
when one converts, so the list stays true.

Run: ``pytest -m corpus`` (part of CI; see docs/corpora.md for its time).
"""

from __future__ import annotations

import os
import tempfile
import time
import warnings
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import pytest

from conftest import corpus_sources

pytestmark = pytest.mark.corpus

SOURCES = dict(corpus_sources())

# id -> why it is refused (a substring of the error). Each is an error of the file itself or
# something the model cannot yet represent; see docs/corpora.md.
REFUSED = {
    "erd/romeo_description/urdf/romeo_laas_small.urdf": "mesh file not found: /usr/Romeo",
    "erd/ur_description/urdf/ur3.urdf": "has no <link>",
    # pybullet_data: Bullet's own extensions and files its loader alone reads.
    "pybullet/biped/biped2d_pybullet.urdf": "lower='-1.57.' is not a list of numbers",
    "pybullet/plane_implicit.urdf": "unknown geometry <plane>",  # urdfdom refuses it too
    "pybullet/toys/concave_box.urdf": "unknown geometry <cdf>",
    "pybullet/torus_deform.urdf": "has no <link>",  # a deformable: <deformable>, no link
    "pybullet/bicycle/bike.urdf": "is not a list of numbers",  # "0.07, 0, -0.69": commas
    "pybullet/husky/husky.urdf": "is not a list of numbers (unexpanded xacro",  # $(optenv ...)
    "pybullet/quadruped/microtaur/microtaur.urdf": "must have 3 number(s)",  # rpy of 4
    "pybullet/racecar/racecar_differential.urdf": "must have 1 or 3 number(s)",  # scale of 4
    "pybullet/kuka_iiwa/model_for_sdf.urdf": "mesh file not found",  # meshes/coarse not shipped
    # MuJoCo itself refuses these MJCF files (written for MuJoCo 1.x or broken).
    "pybullet/mjcf/ground.xml": "not found in tendon",
    "pybullet/mjcf/ground_plane.xml": "plane size(3) must be positive",
    "pybullet/mjcf/half_cheetah.xml": "required attribute missing",
    "pybullet/mjcf/hopper.xml": "global coordinates no longer supported",
    "pybullet/mjcf/walker2d.xml": "global coordinates no longer supported",
    "pybullet/mjcf/humanoid_fixed.xml": "invalid keyword: 'fixed'",
    "pybullet/mjcf/humanoid_symmetric.xml": "material 'geom' not found",
    "pybullet/mjcf/swimmer.xml": "unrecognized attribute: 'collision'",
    # Exported, but the source opens in no reference tool: urdfdom has no "spherical" joint,
    # MuJoCo refuses its ball joint's range.
    "pybullet/spherical_joint_limit.urdf": "check: ",
}
# id -> why an export disagrees with its source (the model drops what makes them agree).
DISAGREES: dict[str, str] = {
}

# What "dynamics carried" compares: mass properties, joint kinds, limits and dynamics.
_NOT_DYNAMICS = ("visual", "collision", "colour", "object name")


def _convert(source: str) -> dict:
    """Load, export to every format, check against the source, read every export back."""
    from real2code_export.check import check_files
    from real2code_export.errors import Real2CodeError
    from real2code_export.formats import export, load
    from real2code_export.model import differences
    from real2code_export.validators import validate_usd

    path, start = SOURCES[source], time.perf_counter()
    out: dict = {"error": None, "mismatches": [], "dynamics": {}}
    with warnings.catch_warnings(record=True) as said, tempfile.TemporaryDirectory() as tmp:
        warnings.simplefilter("always")
        try:
            obj = load(path)
            written = export(obj, Path(tmp) / "out")
        except Real2CodeError as e:
            out["error"] = str(e)
            return out
        repairs = [str(w.message) for w in said]  # the reader's and writers' warnings
        try:
            # the source's dynamics against the exports' too (check's "dynamics" mismatches);
            # an MJCF source's compared in full: no repair of our reader excuses a difference
            report = check_files(list(written.values()), source=path, n_configurations=100,
                                 validate=False, warned=[] if path.suffix == ".xml" else repairs)
        except Real2CodeError as e:  # the source itself opens in no reference tool
            out["error"] = f"check: {e}"
            return out
        out["mismatches"] = [m.message for m in report.mismatches if m.kind != "dynamics"]
        out["source_dynamics"] = [m.message for m in report.mismatches if m.kind == "dynamics"]
        # UsdValidation on the USD (the Node glTF validator, a process per file, is left to
        # the format tests): an export PhysX or Isaac would refuse is not converted
        (usd,) = validate_usd([written["usd"]])
        out["usd_errors"] = usd.messages[:usd.errors]
        for fmt, file in written.items():
            back = load(file)
            out["dynamics"][fmt] = [d for d in differences(obj, back)
                                    if not any(k in d for k in _NOT_DYNAMICS)]
    out["seconds"] = time.perf_counter() - start
    return out


@pytest.fixture(scope="session")
def converted(request):
    """id -> future of :func:`_convert`, for the corpus tests this session runs."""
    wanted = [item.callspec.params["source"] for item in request.session.items
              if item.get_closest_marker("corpus") is not None and hasattr(item, "callspec")
              and item.callspec.params.get("source") in SOURCES
              and SOURCES[item.callspec.params["source"]].is_file()]
    workers = max(1, min(len(os.sched_getaffinity(0)), len(wanted)))
    with ProcessPoolExecutor(workers) as pool:
        yield {s: pool.submit(_convert, s) for s in wanted}


@pytest.mark.parametrize("source", list(SOURCES))
def test_every_corpus_file_converts_and_agrees_with_its_source(source, converted):
    if not SOURCES[source].is_file():
        pytest.skip(f"corpus not found: {SOURCES[source]}")
    result = converted[source].result()
    if source in REFUSED:
        assert result["error"] is not None, f"{source} converts now: take it off REFUSED"
        assert REFUSED[source] in result["error"], result["error"]
        return
    assert result["error"] is None, result["error"]
    if source in DISAGREES:
        assert result["mismatches"], f"{source} agrees now: take it off DISAGREES"
    else:
        assert not result["mismatches"], "\n".join(result["mismatches"][:10])
    assert not result["usd_errors"], "UsdValidation: " + "\n".join(result["usd_errors"][:10])
    for fmt, diffs in result["dynamics"].items():
        assert not diffs, f"{fmt}: " + "\n".join(diffs[:10])
    source_diffs = result.get("source_dynamics", [])
    assert not source_diffs, "source -> export: " + "\n".join(source_diffs[:10])
