"""Values made fit for JSON, which has no NaN or infinity: the one "finite or null" rule every
report (check, calibrate, batch) writes its numbers with."""

from __future__ import annotations

import json
import math
import numbers
from typing import Any


def finite_or_null(value: Any) -> Any:
    """``value`` with every number a plain int or float and every NaN or infinity ``None``,
    through dicts, lists and tuples (tuples become lists); anything else as it is."""
    if value is None or isinstance(value, bool | str):
        return value
    if isinstance(value, dict):
        return {k: finite_or_null(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [finite_or_null(v) for v in value]
    if isinstance(value, numbers.Integral):
        return int(value)
    if isinstance(value, numbers.Real):
        x = float(value)
        return x if math.isfinite(x) else None
    return value


def dumps(value: Any) -> str:
    """``value`` as the JSON every ``--json`` writes: NaN and infinity as null (strict JSON,
    which Python's own ``json`` would otherwise break with a bare ``NaN``), one space indent."""
    return json.dumps(finite_or_null(value), indent=1, allow_nan=False)
