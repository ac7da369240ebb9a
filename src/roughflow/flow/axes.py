"""Flow along both axes of one contact state: the spanning test of the open cells first, a
Reynolds solve only along an axis where the fluid spans (sigma = 0 exactly elsewhere, no
solve), each axis's ordering carried to the next state of a ladder (paper Sect. 2.1-2.2)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from roughflow.errors import ConvergenceError
from roughflow.percolation import percolates_along

from .core import CellOrdering, FlowResult, solve

if TYPE_CHECKING:
    from numpy.typing import ArrayLike


@dataclass(frozen=True)
class AxisFlow:
    """Flow along one axis of a contact state.

    percolating: the open cells span the cell along the axis; result: the Reynolds solve,
    None where they do not (sigma = 0 exactly); ordering: the elimination order to pass to
    the next state's solve along this axis (the solve's own, None after an iterative one;
    the previous state's where there was no solve).
    """

    percolating: bool
    result: FlowResult | None
    ordering: CellOrdering | None = None

    @property
    def sigma(self) -> float:
        """The effective conductance (units of u^3 / eta), 0 where the fluid does not span."""
        return 0.0 if self.result is None else self.result.sigma


def flow_both_axes(gap: ArrayLike, open_mask: ArrayLike, *, lx: float, ly: float,
                   periodic: bool = True, previous: tuple[AxisFlow, AxisFlow] | None = None,
                   **options) -> tuple[AxisFlow, AxisFlow]:
    """:class:`AxisFlow` along x and y of the gap field ``gap`` whose open (non-contact)
    cells are ``open_mask``; ``options`` go to :func:`~roughflow.flow.solve` (``tol``,
    ``sigma_tol``, ``eta``, ``method``, ...). ``previous``: this function's answer for the
    last state of a ladder, whose orderings the solves reuse. A solve that does not converge
    raises its ``ConvergenceError`` with ``inputs`` (gap, axis, lx, ly) to reproduce it."""
    spans = percolates_along(np.asarray(open_mask, dtype=bool), periodic=periodic)
    out = []
    for ax in (0, 1):
        ordering = None if previous is None else previous[ax].ordering
        if not spans[ax]:
            out.append(AxisFlow(False, None, ordering))
            continue
        try:
            r = solve(gap, ax, lx=lx, ly=ly, periodic=periodic, ordering=ordering, **options)
        except ConvergenceError as exc:  # keep what reproduces it (the CLI saves it)
            if exc.inputs is None:
                exc.inputs = {"gap": np.asarray(gap), "axis": ax, "lx": lx, "ly": ly}
            raise
        out.append(AxisFlow(True, r, r.ordering))
    return out[0], out[1]
