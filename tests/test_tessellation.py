"""The primitive shapes' meshes made without trimesh are trimesh.creation's, vertex for
vertex (importing trimesh costs more than a robot's USD export: tessellation.py)."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from real2code_export import tessellation

CASES = {
    "box": [(tessellation.box, ([0.1, 0.02, 0.5],), trimesh.creation.box,
             {"extents": [0.1, 0.02, 0.5]})],
    "cylinder": [(tessellation.cylinder, (r, h, s), trimesh.creation.cylinder,
                  {"radius": r, "height": h, "sections": s})
                 for r, h, s in ((0.05, 0.3, 24), (1.0, 2.0, 32), (0.3, 0.01, 40))],
    "capsule": [(tessellation.capsule, (h, r, c), trimesh.creation.capsule,
                 {"height": h, "radius": r, "count": c})
                for h, r, c in ((0.3, 0.05, [24, 24]), (1.0, 1.0, [24, 12]),
                                (0.2, 0.1, [23, 11]))],
    "icosphere": [(tessellation.icosphere, (d, r), trimesh.creation.icosphere,
                   {"subdivisions": d, "radius": r})
                  for d, r in ((0, 1.0), (1, 0.5), (2, 1.0), (3, 0.07))],
}


@pytest.mark.parametrize("shape", list(CASES))
def test_the_same_meshes_as_trimesh_creation(shape):
    for ours, args, theirs, kwargs in CASES[shape]:
        vertices, faces = ours(*args)
        expected = theirs(**kwargs)
        np.testing.assert_array_equal(vertices, np.asarray(expected.vertices))
        np.testing.assert_array_equal(faces, np.asarray(expected.faces))
        assert trimesh.Trimesh(vertices, faces).is_volume  # closed, wound outward
