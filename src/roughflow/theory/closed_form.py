"""Closed-form conductances from the mean gap and the contact area (paper Eq. 16).

    sigma ~ ubar^3/(12 eta) x  Da'^(69/20)          repulsive (elastic) contacts
                               Da'                  short-range adhesion
                               Da'/(1 - ln Da')     bearing-area models

with Da' = 1 - a_c/a_c*. The prefactors are such that sigma = ubar^3/(12 eta) at
a_c = 0; sigma = 0 for a_c >= a_c*. Units: ubar in L, sigma in L^3/eta.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from roughflow.defaults import DEFAULT_MODEL, MODELS
from roughflow.errors import InputError, require_positive
from roughflow.reynolds import cubic_law

from .effective_medium import _check_a_c_star

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

#: Eq. 16 has one closed form per contact model.
KINDS = MODELS
#: critical exponent beta of sigma ~ Da'^beta near a_c* (bearing: 1 with a log correction)
EXPONENTS = {"elastic": 69.0 / 20.0, "adhesive": 1.0, "bearing": 1.0}


def criticality_factor(a_c: ArrayLike, *, a_c_star: float, kind: str = DEFAULT_MODEL) -> np.ndarray:
    """The factor multiplying ubar^3/(12 eta) in Eq. (16); 1 at a_c = 0, 0 for a_c >= a_c*."""
    a_c_star = _check_a_c_star(a_c_star)
    if kind not in KINDS:
        raise InputError(f"kind must be one of {KINDS}, got {kind!r}")
    a = np.asarray(a_c, dtype=np.float64)
    if not np.isfinite(a).all() or (a < 0).any() or (a > 1).any():
        raise InputError(f"a_c must lie in [0, 1], got {a_c!r}")
    dap = np.clip(1.0 - a / a_c_star, 0.0, 1.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        if kind == "elastic":
            f = dap ** EXPONENTS["elastic"]
        elif kind == "adhesive":
            f = dap
        else:
            f = np.where(dap > 0, dap / (1.0 - np.log(np.where(dap > 0, dap, 1.0))), 0.0)
    return f


def closed_form(
    mean_gap: ArrayLike, a_c: ArrayLike, *, a_c_star: float, kind: str = DEFAULT_MODEL,
    eta: float = 1.0,
) -> np.ndarray | float:
    """Closed-form conductance of Eq. (16) for ``kind`` in ("elastic", "adhesive", "bearing").

    ``mean_gap`` (ubar, >= 0) and ``a_c`` broadcast against each other; returns a float
    for scalar input, an array otherwise.
    """
    eta = require_positive("eta", eta)
    u = np.asarray(mean_gap, dtype=np.float64)
    if not np.isfinite(u).all() or (u < 0).any():
        raise InputError(f"mean_gap must be finite and >= 0, got {mean_gap!r}")
    out = cubic_law(u, eta) * criticality_factor(a_c, a_c_star=a_c_star, kind=kind)
    return float(out) if out.ndim == 0 else out
