"""``real2code view``: a local web page showing an object with a slider per joint.

The page (``web/``: index.html, viewer.js, viewer.css) draws the object's glTF with three.js,
pinned in ``web/package.json`` and installed beside it by ``npm ci`` (scripts/setup.sh); the
server hands out the page, three.js and the object, nothing else, so nothing is fetched from
the network at run time. ``serve`` runs it for a person; ``screenshot`` drives it in headless
Chromium for scripts and tests.
"""

from .screenshot import screenshot
from .server import ViewerServer, serve

__all__ = ["ViewerServer", "screenshot", "serve"]
