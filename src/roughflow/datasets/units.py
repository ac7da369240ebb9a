"""Units strings and grid coordinates shared by every dataset roughflow writes.

The default unit system is dimensionless: lengths in the cell side L, pressures in E* gbar
(contact modulus times rms gradient), viscosity eta = 1, so conductances u^3/(12 eta) are in
L^3/eta.
"""

from __future__ import annotations

import numpy as np

LENGTH_UNITS = "L (cell side; dimensionless)"
PRESSURE_UNITS = "E* gbar (contact modulus times rms gradient; dimensionless)"
SIGMA_UNITS = "L^3 / eta (gap^3 / (12 eta); dimensionless with L = eta = 1)"
FLUX_UNITS = "volume flow per unit width per unit pressure drop (dimensionless)"
RESIDUAL_UNITS = "rms height (largest gap error of the contact solve)"
DIMENSIONLESS = "1"
SECONDS = "s"


def grid_coords(nx: int, ny: int, lx: float, ly: float) -> dict:
    """Cell-centre coordinates x (axis 0) and y (axis 1) with units."""
    x = (np.arange(nx) + 0.5) * lx / nx
    y = (np.arange(ny) + 0.5) * ly / ny
    return {
        "x": ("x", x, {"units": LENGTH_UNITS, "long_name": "position along x (axis 0)"}),
        "y": ("y", y, {"units": LENGTH_UNITS, "long_name": "position along y (axis 1)"}),
    }
