"""Searches that drive contact solves: the load for a target contact area, and the critical
contact area a_c* at which fluid percolation stops.

- :func:`threshold` (:mod:`.critical`): a_c* along x and y from one shared, warm-started
  sequence of contact solves (exact single pass for the bearing model).
- :class:`LoadSearch`, :func:`load_for_area` (:mod:`.load`): loads for target areas on one
  surface, from the contact law (:mod:`roughflow.contact.law`) and the solved states.
- :func:`warm_up` (:mod:`.warmup`): compile the search's numba kernels before a timing.

This layer sits above ``contact`` and ``percolation``, which depend on neither it nor
each other.
"""

from .critical import (
    SearchOptions,
    SolveRecord,
    Threshold,
    ThresholdNotBracketed,
    first_pressure,
    scaled_options,
    threshold,
)
from .load import AreaSolve, LoadSearch, Point, load_for_area, warm_start, warm_start_compliance
from .warmup import warm_up

__all__ = [
    "AreaSolve",
    "LoadSearch",
    "Point",
    "SearchOptions",
    "SolveRecord",
    "Threshold",
    "ThresholdNotBracketed",
    "first_pressure",
    "load_for_area",
    "scaled_options",
    "threshold",
    "warm_start",
    "warm_start_compliance",
    "warm_up",
]
