"""Units strings and grid coordinates shared by every dataset roughflow writes.

Every ``units`` attribute is a unit expression that pint parses (caret powers, ``*`` and
``/``, as udunits also writes them). The solvers work in a dimensionless system with three
reference units, named in the strings:

- ``ref_length`` (L): the cell side of a generated surface (L = sqrt(lx ly) = 1); for an
  imported scan, sqrt(lx ly) of the scan, whose value in metres is recorded at import;
- ``ref_pressure`` (E*): the contact modulus. Generated surfaces have rms gradient
  gbar = 1, so their pressures in E* are also in E* gbar; a scan keeps its own gradient,
  so its pressures are in E* only (the solver itself always works with E* = 1);
- ``ref_viscosity`` (eta): the fluid viscosity; conductances u^3/(12 eta) are in L^3/eta.

Where the values of the reference units are known (a scan's length, the modulus and
viscosity of a leak question), the dataset carries them as the attributes
:data:`REFERENCE_ATTRS` (SI values), and :func:`roughflow.units.registry` defines the
reference units from them, so that xarray + pint give physical numbers. Without them the
reference units are their own base dimensions: the strings still parse, but convert only
among themselves.
"""

from __future__ import annotations

import numpy as np

from roughflow.units import (  # noqa: F401 (re-exported: the names of the dataset units)
    REF_LENGTH,
    REF_PRESSURE,
    REF_VISCOSITY,
    REFERENCE_ATTRS,
    REFERENCE_VARIABLES,
)

#: Fill value of integer variables (NaN cannot be stored in an integer).
INT_FILL = -1


def flags(meanings: str = "false true", dtype: type = np.int32) -> dict:
    """CF ``flag_values`` 0, 1, ... and ``flag_meanings`` (one word per value) of a coded
    integer variable such as a 0/1 mask or yes/no outcome, in the variable's ``dtype``, so
    that CF readers decode it instead of treating 0 and 1 as measurements."""
    words = meanings.split()
    return {"flag_values": np.arange(len(words), dtype=dtype), "flag_meanings": " ".join(words)}


#: Flags of a contact mask (stored as int8).
CONTACT_FLAGS = flags("open contact", np.int8)

LENGTH_UNITS = REF_LENGTH
PRESSURE_UNITS = REF_PRESSURE
#: Local and effective conductance u^3 / (12 eta): volume flow per unit width per unit
#: pressure gradient.
SIGMA_UNITS = f"{REF_LENGTH}^3/{REF_VISCOSITY}"
#: Flux density of a flow solve with a unit pressure drop: volume flow per unit width per
#: unit pressure drop.
FLUX_UNITS = f"{REF_LENGTH}^2/{REF_VISCOSITY}"
#: Energy per area (surface energies, elastic energies of a contact): E* L.
AREAL_ENERGY_UNITS = f"{REF_PRESSURE}*{REF_LENGTH}"
#: Fluid pressure of a flow solve as a fraction of the pressure drop (inlet 1, outlet 0).
FLUID_PRESSURE_UNITS = "1"
#: Contact-solve residual: largest gap error over the rms height (a ratio).
RESIDUAL_UNITS = "1"
DIMENSIONLESS = "1"
SECONDS = "s"

#: Physical (SI) units of the leak datasets.
METRES = "m"
PASCAL = "Pa"
PASCAL_SECONDS = "Pa*s"
#: Conductance per unit width per unit pressure gradient, u^3 / (12 eta).
CONDUCTANCE_SI = "m^3/(Pa*s)"
#: Volume flow rate (the leak rate).
FLOW_RATE_SI = "m^3/s"


def grid_coords(nx: int, ny: int, lx: float, ly: float) -> dict:
    """Cell-centre coordinates x (axis 0) and y (axis 1) with units."""
    x = (np.arange(nx) + 0.5) * lx / nx
    y = (np.arange(ny) + 0.5) * ly / ny
    return {
        "x": ("x", x, {"units": LENGTH_UNITS, "long_name": "position along x (axis 0)"}),
        "y": ("y", y, {"units": LENGTH_UNITS, "long_name": "position along y (axis 1)"}),
    }
