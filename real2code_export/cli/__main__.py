"""``python -m real2code_export.cli ...`` (= ``real2code ...``, with the interpreter's ordinary
exit: ``python -m cProfile -m real2code_export.cli`` writes its profile after it)."""

import sys

from . import no_mujoco_graphics, run

no_mujoco_graphics()
sys.exit(run())
