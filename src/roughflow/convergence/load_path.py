"""ln sigma moved along the load path onto another contact area.

Near the threshold d ln sigma / d a_c ~ -beta / (a_c* - a_c), the elastic exponent of
Eq. 16 (docs/physics.md Sect. 5), with the seed's own reference a_c*(x) where it has one and
the paper's value otherwise.
"""

from __future__ import annotations

import math

from roughflow.defaults import A_C_STAR_PAPER
from roughflow.theory.closed_form import EXPONENTS

BETA, A_STAR = EXPONENTS["elastic"], A_C_STAR_PAPER


def shifted_sigma(sigma: float, area: float, target: float) -> float:
    """sigma measured at contact area ``area`` moved onto ``target`` with the exponent's
    slope (nan where the state does not percolate, ``sigma`` 0)."""
    ln_sig_t = (math.log(sigma) - BETA / (A_STAR - area) * (target - area)
                if sigma > 0 else float("nan"))
    return math.exp(ln_sig_t)


def ln_sigma_at_corrected_area(q: dict, target: float, c: float,
                               a_star: float = A_STAR) -> float:
    """ln sigma at the state whose perimeter-corrected area equals ``target``, from a sigma
    record ``q`` of the resolution study (its fixed-load solve gives the mean-gap slope)."""
    a, a0 = q["a"], q["a_fixed"]
    slope = -BETA / (a_star - a)
    if abs(a - a0) > 1e-4:
        slope += 3 * (math.log(q["mean_gap"]) - math.log(q["gap_fixed"])) / (a - a0)
    a_cor = a - c * q["perim"]
    return math.log(q["sigma_raw"]) + slope * (target - a_cor)
