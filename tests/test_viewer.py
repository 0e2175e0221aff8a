"""``real2code view``: the page in headless Chromium (Debian's, installed by scripts/setup.sh)
with a door set to 60 degrees through its slider. The page's own state must be the model's
forward kinematics, and its screenshot must show the object in that pose: its silhouette is
compared with a ray-cast of the model at the same pose through the page's camera."""

from __future__ import annotations

import io
import json
import math
import urllib.error
import urllib.request
from pathlib import Path

import numpy as np
import pytest

from real2code_export.cli import run
from real2code_export.formats import load
from real2code_export.model import forward_kinematics
from real2code_export.viewer import screenshot
from real2code_export.viewer.server import ViewerServer, model_glb

SAMPLE_CABINET = Path(__file__).resolve().parents[1] / "pipeline" / "samples" / "cabinet" / \
    "object.json"

SIZE = (320, 240)
MIN_IOU = 0.95  # silhouettes of a 320x240 view: anti-aliased edges only
HINGE = "door_4_hinge"  # the door whose swing changes the silhouette most from this view
VIEW = (35.0, 25.0)  # azimuth from the cabinet's +x (its front) towards +y, elevation


def silhouette_of_png(path) -> np.ndarray:
    from PIL import Image

    rgb = np.asarray(Image.open(path).convert("RGB"), dtype=np.int32)
    return (rgb < 245).any(axis=-1)  # the page's background is white


def silhouette_of_model(obj, q: dict, camera_state: dict) -> np.ndarray:
    """The model's parts at ``q`` ray-cast through the page's camera (three.js: OpenGL axes,
    vertical field of view in degrees), in the object's frame."""
    from pipeline.capture import Camera
    from pipeline.render import Raycaster
    from real2code_export.kinematics import world_part_meshes

    width, height = camera_state["width"], camera_state["height"]
    focal = 0.5 * height / math.tan(math.radians(camera_state["fov"]) / 2)
    camera = Camera(focal, focal, width / 2, height / 2, width, height)
    pose = np.array(camera_state["matrix"]).reshape(4, 4).T  # three.js: column-major
    meshes = world_part_meshes(obj, q, np.eye(4))
    caster = Raycaster(list(meshes.values()), [(0.5, 0.5, 0.5, 1.0)] * len(meshes))
    _, _, mask = caster.render(camera, pose)
    return mask > 0


def iou(a: np.ndarray, b: np.ndarray) -> float:
    return float((a & b).sum() / (a | b).sum())


@pytest.fixture(scope="module")
def door_at_60(tmp_path_factory):
    out = tmp_path_factory.mktemp("view") / "door.png"
    closed = {j.name: 0.0 for j in load(SAMPLE_CABINET).movable_joints}
    state = screenshot(SAMPLE_CABINET, out, pose={**closed, HINGE: math.radians(60)},
                       size=SIZE, axes=False, view=VIEW)
    return out, state


def test_page_state_is_forward_kinematics(door_at_60):
    _, state = door_at_60
    obj = load(SAMPLE_CABINET)
    assert state["object"] == obj.name
    assert state["joints"][HINGE] == pytest.approx(math.radians(60), abs=1e-12)
    for joint in obj.movable_joints:  # every other one shut through its slider
        if joint.name != HINGE:
            assert state["joints"][joint.name] == 0.0
    expected = forward_kinematics(obj, state["joints"])
    assert sorted(state["parts"]) == sorted(p.name for p in obj.parts)
    for name, matrix in state["parts"].items():
        got = np.array(matrix).reshape(4, 4).T
        assert np.abs(got - expected[name]).max() < 1e-9, name


def test_screenshot_shows_the_pose(door_at_60):
    path, state = door_at_60
    obj = load(SAMPLE_CABINET)
    shown = silhouette_of_png(path)
    assert shown.shape == (SIZE[1], SIZE[0])
    posed = silhouette_of_model(obj, state["joints"], state["camera"])
    closed = silhouette_of_model(obj, {**state["joints"], HINGE: 0.0}, state["camera"])
    assert iou(shown, posed) > MIN_IOU
    # and the comparison can tell: the same view with that door shut does not match
    assert iou(shown, closed) < iou(shown, posed) - 0.05


def test_command_writes_the_screenshot(tmp_path, capsys):
    out = tmp_path / "shot.png"
    assert run(["view", str(SAMPLE_CABINET), "--screenshot", str(out), "--pose",
                f"{HINGE}=60deg", "--size", "200x150", "--panel"]) == 0
    from PIL import Image

    assert Image.open(io.BytesIO(out.read_bytes())).size == (200, 150)
    assert f"{HINGE} = 1.047" in capsys.readouterr().out  # 60 degrees in radians


@pytest.mark.parametrize("args, message", [
    (["--pose", "no_such_joint=1"], "no movable joint named 'no_such_joint'"),
    (["--pose", "door_0_hinge"], "expected JOINT=VALUE"),
    (["--size", "big"], "--size 'big'"),
])
def test_bad_input_writes_nothing(tmp_path, capsys, args, message):
    out = tmp_path / "shot.png"
    assert run(["view", str(SAMPLE_CABINET), "--screenshot", str(out), *args]) == 2
    assert message in capsys.readouterr().err
    assert not out.exists()


def test_missing_file_is_bad_input(tmp_path, capsys):
    assert run(["view", str(tmp_path / "nope.urdf"), "--screenshot", str(tmp_path / "a.png")]) \
        == 2
    assert "nope.urdf" in capsys.readouterr().err


def test_server_serves_the_page_three_and_the_object_only():
    import threading

    server = ViewerServer(model_glb(SAMPLE_CABINET))
    threading.Thread(target=server.serve_forever, daemon=True).start()
    try:
        def get(path):
            with urllib.request.urlopen(server.url.rstrip("/") + path, timeout=10) as r:
                return r.headers["Content-Type"], r.read()

        kind, body = get("/model.glb")
        assert kind == "model/gltf-binary" and body[:4] == b"glTF"
        assert get("/")[0].startswith("text/html")
        assert get("/three/build/three.module.js")[0].startswith("text/javascript")
        for path in ("/three/../package.json", "/three/%2e%2e/viewer.js", "/etc/passwd"):
            with pytest.raises(urllib.error.HTTPError) as e:
                get(path)
            assert e.value.code == 404
        request = urllib.request.Request(server.url + "state", data=json.dumps({"a": 1}).encode())
        with urllib.request.urlopen(request, timeout=10):
            pass
        assert server.states == [{"a": 1}]
    finally:
        server.shutdown()
        server.server_close()
