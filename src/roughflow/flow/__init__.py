"""Reynolds flow through the gap of a rough contact (paper Sect. 2.1, Eq. 3-4).

``solve(gap, axis, ...) -> FlowResult`` and ``conductance(gap, axis=None, ...)`` (a float, or
``Conductances(sigma_x, sigma_y)`` for both axes) compute the effective conductances sigma_x,
sigma_y by cell-centred finite volumes with AMG-preconditioned CG (or a direct solver);
``flow_both_axes`` solves only along the axes where the open cells of a contact state span
(a ladder's steps). ``roughflow.figures.flux.plot_flux`` draws the flux over the contact map.
"""

from .axes import AxisFlow, flow_both_axes
from .core import CellOrdering, Conductances, FlowResult, check_sigma_tol, conductance, solve

__all__ = ["AxisFlow", "CellOrdering", "Conductances", "FlowResult", "check_sigma_tol",
           "conductance", "flow_both_axes", "solve"]
