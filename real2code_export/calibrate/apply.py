"""Write a fit into the model: native dynamics into ``Joint.dynamics`` / ``Joint.limits`` /
the parts' inertials (every exporter writes those), the rest into the namespaced metadata
(``extras``)."""

from __future__ import annotations

import copy

from ..model import ArticulatedObject, validate
from . import extras as ex
from .fit import Fit
from .problem import FRICTION_TIMECONST


def calibrated_object(obj: ArticulatedObject, fit: Fit) -> ArticulatedObject:
    """A copy of ``obj`` carrying the fitted effects."""
    out = copy.deepcopy(obj)
    by_joint: dict[str, list] = {}
    for e in fit.effects:
        by_joint.setdefault(e.joint, []).append(e)
    for joint, effects in by_joint.items():
        extras = dict(ex.joint_extras(out, joint))
        for e in effects:
            if e.name in ("offset", "asymmetric_friction", "limit", "encoder_offset",
                          "effort_delay"):
                extras.pop(e.name, None)
            e.apply_to_model(out, fit.effect_values(e), extras)
        if out.joint(joint).dynamics.friction > 0:
            # the stick the fit saw: dry friction as stiff as a 1 ms step allows
            extras["friction"] = {"timeconst": FRICTION_TIMECONST, "dampratio": 1.0}
        ex.set_joint_extras(out, joint, extras)
    return validate(out)
