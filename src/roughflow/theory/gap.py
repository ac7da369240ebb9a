"""Every effective-medium and closed-form prediction for one gap field (paper Eq. 5-16).

:func:`gap_theory` is what the command line (``roughflow theory CONTACT.nc``) and the
pressure ladder evaluate on each contact state: the isotropic Bruggeman conductance
(Eq. 5-6), both anisotropic forms (Persson's Eq. 7-8 and the corrected Eq. 9), the closed
form of Eq. 16 and, on request, the non-contact conductivity of Eq. 13.

Continuum area. The Bruggeman sums run over grid cells, whose contact fraction exceeds the
continuum contact area by the grid bias (docs/accuracy.md). Given a continuum estimate
``area_fraction`` (e.g. perimeter-corrected), the thresholds of the Bruggeman forms are
shifted by the same bias, so that every a_c* refers to the continuum area, as the closed
form's does; without the shift the full Bruggeman line would vanish at a grid fraction of
0.4, a continuum area of 0.34 at 2 points per lambda_s.

Units: gap in L, conductivities u^3/(12 eta) in L^3/eta.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from roughflow.defaults import DEFAULT_MODEL
from roughflow.errors import plain_array, require_finite, require_mask

from .closed_form import closed_form
from .effective_medium import (
    AnisotropicResult,
    bruggeman,
    bruggeman_anisotropic,
    local_conductivity,
    medium,
    noncontact_decomposition,
)

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

# keeps a shifted threshold inside (0, 1), where D = 1/(1 - a_c*) is finite
_MAX_GRID_THRESHOLD = 0.999


@dataclass(frozen=True)
class GapTheory:
    """Predictions for one gap field.

    grid_area_fraction: fraction of contact cells (of cells with sigma = 0 without a contact
    mask); area_fraction: the contact area
    the closed form and the thresholds refer to (= grid_area_fraction unless a continuum
    estimate was given); mean_gap: mean gap over the cell; peklenik: Peklenik number of
    the anisotropic forms; sigma_isotropic (Eq. 5-6) and its residual; sigma_alt: the
    isotropic form with ``a_c_star_alt`` (NaN if none); corrected (Eq. 9) and persson
    (Eq. 7-8): :class:`~roughflow.theory.AnisotropicResult`; sigma_closed_form (Eq. 16);
    sigma_nc (Eq. 13, NaN unless asked for and defined); residual: the largest of the
    self-consistent equations' residuals.
    """

    grid_area_fraction: float
    area_fraction: float
    mean_gap: float
    peklenik: float
    sigma_isotropic: float
    isotropic_residual: float
    sigma_alt: float
    corrected: AnisotropicResult
    persson: AnisotropicResult
    sigma_closed_form: float
    sigma_nc: float
    residual: float


def gap_theory(gap: ArrayLike, *, a_c_star: float, contact: ArrayLike | None = None,
               gamma: float = 1.0, kind: str = DEFAULT_MODEL, eta: float = 1.0,
               area_fraction: float | None = None, a_c_star_alt: float | None = None,
               noncontact: bool = False) -> GapTheory:
    """Bruggeman (isotropic, both anisotropic forms) and Eq. 16 for one gap field.

    ``contact``: boolean contact mask (default gap <= 0); ``gamma``: Peklenik number of the
    anisotropic forms; ``kind``: closed form of Eq. 16; ``area_fraction``: continuum estimate
    of the contact area (module docstring); ``a_c_star_alt``: a second threshold for the
    isotropic form; ``noncontact``: also solve Eq. 13 for sigma_nc (defined while some
    fluid cell is open and a_c <= a_c*).
    """
    from roughflow.resources import check_memory

    gap = plain_array("gap", gap)
    check_memory("theory", gap.size, what="the gap theory")
    if contact is not None:
        contact = require_mask("contact mask", contact)
    sig = local_conductivity(gap, eta, contact=contact).ravel()
    # contact cells; an open cell with a gap of exactly 0 (the bearing model's critical cell)
    # also has sigma = 0 but is not contact
    grid_a = float(np.mean(sig == 0.0) if contact is None else np.mean(contact))
    shift = 0.0
    if area_fraction is not None:
        area_fraction = require_finite("area_fraction", area_fraction)
        shift = max(grid_a - area_fraction, 0.0)

    def on_grid(a_star: float) -> float:
        return min(a_star + shift, _MAX_GRID_THRESHOLD)

    # one distribution for every form, which shares the roots of equations they have in
    # common (all of them at gamma = 1)
    m = medium(sig)
    iso = bruggeman(m, a_c_star=on_grid(a_c_star))
    a_c = iso.a_c if area_fraction is None else area_fraction
    alt = (bruggeman(m, a_c_star=on_grid(a_c_star_alt)).sigma if a_c_star_alt is not None
           else math.nan)
    cor = bruggeman_anisotropic(m, a_c_star=on_grid(a_c_star), gamma=gamma, form="corrected")
    per = bruggeman_anisotropic(m, a_c_star=on_grid(a_c_star), gamma=gamma, form="persson")
    nc = math.nan
    if noncontact and 0 < (sig > 0).mean() and iso.a_c <= on_grid(a_c_star):
        nc = noncontact_decomposition(m, a_c_star=on_grid(a_c_star)).sigma_nc
    ubar = float(gap.mean())
    return GapTheory(
        grid_area_fraction=grid_a, area_fraction=a_c, mean_gap=ubar, peklenik=float(gamma),
        sigma_isotropic=float(iso.sigma), isotropic_residual=float(iso.residual),
        sigma_alt=float(alt), corrected=cor, persson=per,
        sigma_closed_form=float(closed_form(ubar, a_c, a_c_star=a_c_star, kind=kind, eta=eta)),
        sigma_nc=float(nc), residual=float(max(iso.residual, cor.residual, per.residual)),
    )
