"""The viewer driven by headless Chromium: a PNG of the page at a pose, and the state the page
reported (each part's matrix and the camera, in the object's frame).

Debian's ``chromium`` (or ``$REAL2CODE_CHROMIUM``) renders WebGL without a GPU through
SwiftShader. The pose is set through the page's own sliders (its ``pose`` parameter moves
each slider and fires its input event, as a hand on the slider does).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import tempfile
import threading
from pathlib import Path
from urllib.parse import urlencode

from .. import atomic
from ..errors import CheckError, InputError, UnavailableError
from .server import ViewerServer

CHROMIUM_NAMES = ("chromium", "chromium-browser", "google-chrome")
# headless, software WebGL, and nothing that reaches for the network (closed machines refuse
# those connections, many at a time)
CHROMIUM_FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--enable-unsafe-swiftshader",
                  "--use-angle=swiftshader", "--disable-quic", "--no-first-run",
                  "--disable-background-networking", "--disable-component-update",
                  "--disable-sync", "--hide-scrollbars", "--force-device-scale-factor=1",
                  "--virtual-time-budget=20000")
TIMEOUT_S = 120.0


def find_chromium() -> str:
    named = os.environ.get("REAL2CODE_CHROMIUM")
    if named:
        if not Path(named).is_file():
            raise UnavailableError(f"REAL2CODE_CHROMIUM={named}: no such file")
        return named
    for name in CHROMIUM_NAMES:
        found = shutil.which(name)
        if found:
            return found
    raise UnavailableError("headless screenshots need Chromium: install Debian's chromium "
                           "(apt-get install chromium) or set REAL2CODE_CHROMIUM")


def screenshot(path: str | Path, out: str | Path, *, pose: dict[str, float] | None = None,
               size: tuple[int, int] = (640, 480), view: tuple[float, float] = (-30.0, 25.0),
               panel: bool = False, axes: bool = True) -> dict:
    """Write ``out`` (PNG): the page showing ``path`` with each joint in ``pose`` set through
    its slider (others at their observed state); returns the state the page reported."""
    from ..formats import load
    from ..formats.gltf.write import build

    obj = load(path)
    pose = dict(pose or {})
    movable = {j.name for j in obj.movable_joints}
    unknown = sorted(set(pose) - movable)
    if unknown:
        raise InputError(f"{path}: no movable joint named {', '.join(map(repr, unknown))}; "
                         f"the object has {', '.join(sorted(movable)) or 'none'}")
    width, height = size
    if width < 16 or height < 16:
        raise InputError(f"screenshot size {width}x{height}: at least 16x16 pixels")
    chromium = find_chromium()
    server = ViewerServer(build(obj))
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    query = {"report": "1", "panel": "1" if panel else "0", "axes": "1" if axes else "0",
             "view": f"{view[0]:g},{view[1]:g}"}
    if pose:
        query["pose"] = ",".join(f"{name}:{value!r}" for name, value in pose.items())
    try:
        with tempfile.TemporaryDirectory(prefix="real2code-view-") as tmp:
            shot = Path(tmp) / "shot.png"
            command = [chromium, *CHROMIUM_FLAGS, f"--user-data-dir={tmp}/profile",
                       f"--window-size={width},{height}", f"--screenshot={shot}",
                       f"{server.url}?{urlencode(query)}"]
            try:
                done = subprocess.run(command, capture_output=True, text=True,
                                      timeout=TIMEOUT_S, check=False)
            except subprocess.TimeoutExpired as e:
                raise CheckError(f"{chromium} took over {TIMEOUT_S:g} s") from e
            if done.returncode != 0 or not shot.is_file():
                raise CheckError(f"{chromium} failed ({done.returncode}): "
                                 f"{done.stderr.strip()[-800:]}")
            if not server.reported.wait(5.0):
                raise CheckError(f"the viewer page never reported its state ({server.url})")
            state = server.states[-1]
            if "error" in state:
                raise CheckError(f"the viewer page failed: {state['error']}")
            atomic.write_bytes(out, shot.read_bytes())
    finally:
        server.shutdown()
        server.server_close()
    return state
