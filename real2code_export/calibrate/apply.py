"""Write a fit into the model: native dynamics into ``Joint.dynamics`` / ``Joint.limits`` /
the parts' inertials (every exporter writes those), the rest into the namespaced metadata
(``extras``)."""

from __future__ import annotations

import copy
import dataclasses

import numpy as np

from ..model import ArticulatedObject, validate
from . import extras as ex
from .fit import Fit
from .inertial import base_parameters
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


def base_parameter_halfwidths(obj: ArticulatedObject, fit: Fit, joint: str) -> dict:
    """95 % half-widths of the calibrated model's base inertial parameters of ``joint``
    (:func:`inertial.base_parameters`, the first moment in the nominal model's
    directions): the fit's covariance of the parameters that move them carried through
    (first order, by differences); empty where the fit changes none of them."""
    keys = [p.key for e in fit.effects if e.joint == joint and e.name == "inertia"
            for p in e.params]
    if not keys:
        return {}
    nominal = base_parameters(obj, joint)
    directions = np.array(nominal.get("first_moment_directions", np.zeros((0, 3))))

    def flat(values: dict[str, float]) -> np.ndarray:
        b = base_parameters(calibrated_object(obj, dataclasses.replace(fit, values=values)),
                            joint)
        if "moving_mass" in b:
            return np.array([b["moving_mass"]])
        moment = np.array(b["first_moment_directions"]).T @ np.array(b["first_moment"])
        return np.concatenate([[b["inertia_about_axis"]], directions @ moment])

    at = flat(fit.values)
    grad = np.zeros((len(at), len(keys)))
    for i, k in enumerate(keys):
        h = 1e-6 * max(abs(fit.values[k]), 1e-3)
        grad[:, i] = (flat({**fit.values, k: fit.values[k] + h}) - at) / h
    cov = np.array([[fit.cov.get((a, b), np.inf if a == b else 0.0) for b in keys]
                    for a in keys])
    with np.errstate(invalid="ignore"):
        var = np.einsum("ij,jk,ik->i", grad, cov, grad)
    half = [float(1.96 * np.sqrt(v)) if np.isfinite(v) and v >= 0 else None for v in var]
    if "moving_mass" in nominal:
        return {"moving_mass": half[0]}
    return {"inertia_about_axis": half[0], "first_moment": half[1:]}
