"""The Reynolds thin-film law of the local conductivity (paper Eq. 3), written once for the
flow solver and the theory: sigma(r) = u_g(r)^3 / (12 eta)."""

from __future__ import annotations

import numpy as np

__all__ = ["cubic_law"]


def cubic_law(gap: np.ndarray | float, eta: float = 1.0) -> np.ndarray:
    """Local conductivity u^3 / (12 eta) of a gap (units L^3/eta); no input checks (the
    callers validate), overflow to inf left to the caller to refuse."""
    with np.errstate(over="ignore"):
        return np.asarray(gap, dtype=np.float64) ** 3 / (12.0 * eta)
