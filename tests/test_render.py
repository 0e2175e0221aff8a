"""Synthetic captures: depth lands on the surfaces, masks name the part that was hit, the
cameras see the object whole from its front, and ``real2code render`` writes a capture
folder with the ground truth beside it."""

from __future__ import annotations

import argparse
import json

import numpy as np
import pytest
import trimesh

from pipeline.capture import read_capture
from pipeline.fuse import part_clouds, point_map
from pipeline.procedural import generate
from pipeline.render import front_direction, render_object
from real2code_export.cli.reconstruct import add_render_parser
from real2code_export.errors import InputError
from real2code_export.formats import load
from real2code_export.kinematics import world_part_meshes
from real2code_export.model import forward_kinematics

from conftest import partnet_objects


@pytest.fixture(scope="module")
def cabinet():
    obj = generate("storage_furniture", 5, 7)
    return obj, render_object(obj, views=6, width=96, height=80, seed=3)


def test_depth_and_masks_match_the_meshes(cabinet):
    obj, cap = cabinet
    meshes = world_part_meshes(obj)
    parts = {n: meshes[n].to_trimesh() for n in cap.parts}
    for frame in cap.frames[::2]:
        assert frame.rgb.shape == (80, 96, 3) and frame.mask.shape == (80, 96)
        pts, valid = point_map(frame)
        assert np.array_equal(valid, frame.mask > 0)  # every hit has a part, nothing else
        rows, cols = np.nonzero(valid)
        pick = np.random.default_rng(0).choice(len(rows), 200, replace=False)
        for r, c in zip(rows[pick], cols[pick], strict=True):
            name = cap.parts[frame.mask[r, c] - 1]
            _, dist, _ = trimesh.proximity.closest_point(parts[name], pts[r, c][None])
            assert dist[0] < 1e-4, f"pixel {(r, c)} of part {name} is {dist[0]} m off it"


def test_every_part_is_seen_and_the_object_fits(cabinet):
    obj, cap = cabinet
    clouds = part_clouds(cap)
    assert sorted(clouds) == list(range(1, len(obj.parts) + 1))
    for frame in cap.frames:  # the object fits: no part touches the image border
        border = np.concatenate([frame.mask[0], frame.mask[-1], frame.mask[:, 0],
                                 frame.mask[:, -1]])
        assert not border.any()


def test_front_arc_cameras_face_the_front():
    obj = generate("storage_furniture", 4, 2)
    assert front_direction(obj) @ [1, 0, 0] > 0.9  # its doors open towards +x
    base = np.eye(4)
    base[:3, :3] = [[0, -1, 0], [1, 0, 0], [0, 0, 1]]  # turned 90 degrees: front is +y
    cap = render_object(obj, base=base, views=4, width=32, height=32, cameras="front-arc")
    front = front_direction(obj, base)
    assert front[1] > 0.9
    for frame in cap.frames:
        view_dir = -frame.camera_to_world[:3, 2]  # cameras look down -z
        horizontal = view_dir[:2] / np.linalg.norm(view_dir[:2])
        assert horizontal @ -front[:2] > np.cos(np.radians(75))  # within the arc (+ jitter)
    assert cap.object_pose().tolist() == base.tolist()


def _azimuths(cap):
    """Each camera's azimuth seen from the point it looks at."""
    back = np.array([f.camera_to_world[:3, 2] for f in cap.frames])  # cameras look down -z
    return np.degrees(np.arctan2(back[:, 1], back[:, 0]))


def test_camera_paths_know_nothing_of_the_joints():
    """The default path is a full ring; the same seed gives the same ring whichever way the
    object opens, and half rings, hand-held and far paths keep the object whole in view."""
    obj = generate("storage_furniture", 4, 2)
    turned = np.eye(4)
    turned[:3, :3] = [[0, -1, 0], [1, 0, 0], [0, 0, 1]]
    a = render_object(obj, views=8, width=48, height=48, seed=4)
    b = render_object(obj, base=turned, views=8, width=48, height=48, seed=4)
    assert a.extra["camera_path"] == "ring"
    assert np.allclose(_azimuths(a), _azimuths(b), atol=1e-6)  # not steered by the front
    gaps = np.diff(np.sort(_azimuths(a)))
    assert np.allclose(gaps, 45.0, atol=1e-6)  # eight views, evenly round
    for path, distance in (("half-ring", "mid"), ("handheld", "near"), ("ring", "far")):
        cap = render_object(obj, views=8, width=64, height=64, seed=1, cameras=path,
                            distance=distance)
        for frame in cap.frames:
            assert frame.mask.any()
            edge = np.concatenate([frame.mask[0], frame.mask[-1], frame.mask[:, 0],
                                   frame.mask[:, -1]])
            assert edge.mean() < 0.05, (path, distance)  # (nearly) whole in view
        if path == "half-ring":
            span = np.ptp(np.unwrap(np.radians(_azimuths(cap))))
            assert np.isclose(np.degrees(span), 180.0, atol=1e-6)
        if path == "handheld":
            steps = np.diff(np.unwrap(np.radians(_azimuths(cap))))
            assert steps.std() > 0.1 * abs(steps.mean())  # uneven spacing
    with pytest.raises(InputError, match="unknown camera path"):
        render_object(obj, views=2, width=16, height=16, cameras="spiral")


def test_deterministic():
    obj = generate("box", 2, 0)
    a = render_object(obj, views=3, width=40, height=40, seed=5)
    b = render_object(obj, views=3, width=40, height=40, seed=5)
    c = render_object(obj, views=3, width=40, height=40, seed=6)
    assert all(np.array_equal(x.rgb, y.rgb) and np.array_equal(x.depth, y.depth)
               for x, y in zip(a.frames, b.frames, strict=True))
    assert not np.array_equal(a.frames[0].camera_to_world, c.frames[0].camera_to_world)


def _run_render(argv):
    parser = argparse.ArgumentParser()
    add_render_parser(parser.add_subparsers())
    args = parser.parse_args(["render", *argv])
    return args.func(args)


def test_render_command_writes_capture_and_ground_truth(tmp_path):
    obj = generate("refrigerator", 3, 4)
    from real2code_export.formats import object_json

    object_json.save(obj, tmp_path / "model")
    out = tmp_path / "capture"
    assert _run_render([str(tmp_path / "model" / "object.json"), "--out", str(out), "--views",
                        "3", "--width", "48", "--height", "40", "--state", "random",
                        "--seed", "9"]) == 0
    cap = read_capture(out)
    assert len(cap.frames) == 3 and cap.frames[0].depth.shape == (40, 48)
    truth = load(cap.ground_truth_path())
    assert [p.name for p in truth.parts] == cap.parts
    rendered = json.loads((out / "transforms.json").read_text())["real2code"]["state"]
    assert rendered == pytest.approx(truth.observed_configuration())
    assert rendered != pytest.approx(obj.observed_configuration())  # a new random state
    # the ground truth at its state is what the frames show
    poses = forward_kinematics(truth, truth.observed_configuration())
    pts, valid = point_map(cap.frames[1])
    k = cap.parts.index(truth.movable_joints[0].child) + 1
    part = truth.part(cap.parts[k - 1])
    mesh = part.visual.transformed(poses[part.name]).to_trimesh()
    sel = pts[valid & (cap.frames[1].mask == k)]
    assert len(sel) > 0
    _, dist, _ = trimesh.proximity.closest_point(mesh, sel[:100])
    assert dist.max() < 1e-3


@pytest.mark.partnet
@pytest.mark.filterwarnings("ignore::real2code_export.errors.Real2CodeWarning")
def test_partnet_object_renders_one_mask_per_rigid_part(tmp_path):
    folder = partnet_objects("dev")[0]
    assert _run_render([str(folder / "mobility.urdf"), "--out", str(tmp_path / "c"),
                        "--views", "4", "--width", "64", "--height", "64"]) == 0
    cap = read_capture(tmp_path / "c")
    truth = load(cap.ground_truth_path())
    assert not [j for j in truth.joints if j.type.value == "fixed"]  # welded parts merged
    seen = set()
    for frame in cap.frames:
        seen |= set(np.unique(frame.mask).tolist())
    assert seen - {0} <= set(range(1, len(cap.parts) + 1)) and len(seen - {0}) >= 2


def test_render_command_takes_a_camera_path_and_a_sensor(tmp_path):
    from real2code_export.errors import FormatError
    from real2code_export.formats import object_json

    object_json.save(generate("box", 2, 1), tmp_path / "model")
    model = str(tmp_path / "model" / "object.json")
    out = tmp_path / "capture"
    assert _run_render([model, "--out", str(out), "--views", "4", "--width", "48", "--height",
                        "48", "--cameras", "handheld", "--distance", "far",
                        "--capture", "phone-lidar"]) == 0
    doc = json.loads((out / "transforms.json").read_text())["real2code"]
    assert doc["camera_path"] == "handheld" and doc["camera_distance"] == "far"
    assert doc["sensor"]["name"] == "phone-lidar"
    cap = read_capture(out)
    assert any(((f.mask > 0) & (f.depth == 0)).any() for f in cap.frames)  # depth went missing
    bad = tmp_path / "sensor.json"
    bad.write_text('{"noise_a": "high"}')
    with pytest.raises(FormatError, match="noise_a"):
        _run_render([model, "--out", str(tmp_path / "c2"), "--capture", str(bad)])
    assert not (tmp_path / "c2").exists()
