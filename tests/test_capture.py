"""The capture folder: what is written reads back, and broken folders are refused with a
message naming the file, the frame and what is wrong."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest
from PIL import Image

from pipeline.capture import Camera, Capture, Frame, read_capture, write_capture
from real2code_export.errors import FormatError


def _capture(n: int = 2, masks: bool = True, cameras=None) -> Capture:
    rng = np.random.default_rng(0)
    frames = []
    for k in range(n):
        cam = cameras[k] if cameras else Camera(40.0, 41.0, 16.0, 12.5, 32, 24)
        pose = np.eye(4)
        angle = 0.3 * k
        pose[:3, :3] = [[np.cos(angle), -np.sin(angle), 0], [np.sin(angle), np.cos(angle), 0],
                        [0, 0, 1]]
        pose[:3, 3] = [k, 2.0, 1.5]
        depth = rng.uniform(0.5, 3.0, (cam.height, cam.width)).astype(np.float32)
        depth[:3] = 0.0  # no measurement
        mask = rng.integers(0, 3, (cam.height, cam.width)).astype(np.uint16) if masks else None
        rgb = rng.integers(0, 256, (cam.height, cam.width, 3)).astype(np.uint8)
        frames.append(Frame(cam, pose, rgb, depth, mask))
    return Capture(frames, ["body", "door_0"] if masks else [], {"note": "test"})


def test_round_trip(tmp_path):
    cap = _capture()
    write_capture(cap, tmp_path / "c")
    back = read_capture(tmp_path / "c")
    doc = json.loads((tmp_path / "c" / "transforms.json").read_text())
    assert doc["depth_unit_scale_factor"] == 1e-4 and doc["fl_x"] == 40.0  # shared intrinsics
    assert back.parts == ["body", "door_0"] and back.extra == {"note": "test"}
    for a, b in zip(cap.frames, back.frames, strict=True):
        assert a.camera == b.camera
        np.testing.assert_allclose(a.camera_to_world, b.camera_to_world, atol=1e-9)
        np.testing.assert_array_equal(a.rgb, b.rgb)
        np.testing.assert_array_equal(a.mask, b.mask)
        assert np.abs(a.depth - b.depth).max() <= 0.5e-4 + 1e-7
        assert np.array_equal(a.depth == 0, b.depth == 0)


def test_per_frame_intrinsics_and_no_masks(tmp_path):
    cams = [Camera(40.0, 40.0, 16.0, 12.0, 32, 24), Camera(30.0, 30.0, 10.0, 8.0, 20, 16)]
    write_capture(_capture(masks=False, cameras=cams), tmp_path / "c")
    doc = json.loads((tmp_path / "c" / "transforms.json").read_text())
    assert "fl_x" not in doc and doc["frames"][1]["w"] == 20
    back = read_capture(tmp_path / "c" / "transforms.json")
    assert [f.camera for f in back.frames] == cams and not back.has_masks


def test_far_depth_uses_a_coarser_unit(tmp_path):
    cap = _capture(1)
    cap.frames[0].depth[5, 5] = 20.0  # beyond 6.5 m: millimetres
    write_capture(cap, tmp_path / "c")
    back = read_capture(tmp_path / "c")
    assert json.loads((tmp_path / "c" / "transforms.json").read_text())[
        "depth_unit_scale_factor"] == 1e-3
    assert back.frames[0].depth[5, 5] == pytest.approx(20.0, abs=1e-3)


def test_failed_write_leaves_nothing(tmp_path):
    cap = _capture(1)
    cap.frames[0].depth[0, 0] = 1e5  # too far for any 16-bit unit
    with pytest.raises(FormatError, match="too far"):
        write_capture(cap, tmp_path / "c")
    assert not (tmp_path / "c").exists()


@pytest.fixture
def folder(tmp_path):
    write_capture(_capture(), tmp_path / "c")
    return tmp_path / "c"


def _edit(folder, change):
    path = folder / "transforms.json"
    doc = json.loads(path.read_text())
    change(doc)
    path.write_text(json.dumps(doc))


def test_missing_transforms(tmp_path):
    with pytest.raises(FormatError, match="transforms.json: no such file"):
        read_capture(tmp_path)


def test_invalid_json(folder):
    (folder / "transforms.json").write_text("{\n  'frames': [\n")
    with pytest.raises(FormatError, match=r"transforms.json:2: not valid JSON"):
        read_capture(folder)


@pytest.mark.parametrize(("change", "message"), [
    (lambda d: d.update(frames=[]), r"frames: expected a non-empty 'frames' list"),
    (lambda d: d.pop("fl_y"), r"frames\[0\]: missing camera intrinsic 'fl_y'"),
    (lambda d: d.update(w=-3), r"frames\[0\]: camera intrinsic 'w' must be"),
    (lambda d: d["frames"][1].pop("transform_matrix"), r"frames\[1\]: missing 'transform_matrix'"),
    (lambda d: d["frames"][1]["transform_matrix"][0].__setitem__(0, 2.0),
     r"frames\[1\]: 'transform_matrix' is not a rigid"),
    (lambda d: d["frames"][0].pop("depth_file_path"), r"frames\[0\]: missing 'depth_file_path'"),
    (lambda d: d.update(depth_unit_scale_factor=0), r"depth_unit_scale_factor: must be positive"),
    (lambda d: d.update(parts=["body"]), r"mask holds part index 2 but 'parts' lists 1"),
])
def test_broken_transforms(folder, change, message):
    _edit(folder, change)
    with pytest.raises(FormatError, match=message):
        read_capture(folder)


def test_missing_image(folder):
    (folder / "images" / "frame_00001.png").unlink()
    with pytest.raises(FormatError, match=r"images/frame_00001.png: frames\[1\] file_path: "
                                          r"no such file"):
        read_capture(folder)


def test_eight_bit_depth_is_refused(folder):
    Image.fromarray(np.zeros((24, 32), np.uint8)).save(folder / "depth" / "frame_00000.png")
    with pytest.raises(FormatError, match=r"depth/frame_00000.png: frames\[0\] depth_file_path:"
                                          r" expected a single-channel 16-bit PNG"):
        read_capture(folder)


def test_image_size_must_match_camera(folder):
    shutil.copy(folder / "images" / "frame_00000.png", folder / "spare.png")
    Image.fromarray(np.zeros((10, 10, 3), np.uint8)).save(folder / "images" / "frame_00001.png")
    with pytest.raises(FormatError, match=r"frame_00001.png: frames\[1\]: size 10x10 differs "
                                          r"from the camera's 32x24"):
        read_capture(folder)
