"""Short reprs of the result dataclasses: a field holding a large array shows its dtype and
shape, not pages of digits (a notebook printing a result showed the gap's values before any
scalar)."""

from __future__ import annotations

import dataclasses

import numpy as np

#: Arrays up to this many elements are shown in full (a few pressures of a curve).
SHOWN_IN_FULL = 16


def summary_repr(obj: object) -> str:
    """``Name(field=value, ...)`` over the dataclass's repr fields, an array of more than
    :data:`SHOWN_IN_FULL` elements as ``array(float64, 128 x 256)``."""
    parts = []
    for f in dataclasses.fields(obj):
        if not f.repr:
            continue
        value = getattr(obj, f.name)
        if isinstance(value, np.ndarray) and value.size > SHOWN_IN_FULL:
            text = f"array({value.dtype}, {' x '.join(map(str, value.shape))})"
        else:
            text = repr(value)
        parts.append(f"{f.name}={text}")
    return f"{type(obj).__name__}({', '.join(parts)})"
