"""Direction-dependent correlation lengths and the conductivity Peklenik number.

Definition (used for the paper's "conductivity Peklenik number", Sect. 3.3): let
C(r) be the normalised autocorrelation function of the fluctuations of a field f(r)
on the periodic cell, C(r) = <df(r' + r) df(r')> / <df^2>, computed with FFTs. The
correlation length along x (y) is the distance xi_x (xi_y) at which C first drops
to ``level`` (default 1/e) along the x (y) axis, found by linear interpolation
between grid points. The Peklenik number is gamma_f = xi_x / xi_y.

For a Peklenik-stretched field f(x, y) = f_iso(x/sqrt(gamma), y sqrt(gamma)) (the
paper's Eq. 1 in real space) C(x, 0) = C_iso(x/sqrt(gamma)) and
C(0, y) = C_iso(y sqrt(gamma)), so xi_x/xi_y = gamma at any level: applied to the
heights, the definition returns the height Peklenik number. The conductivity
Peklenik number applies it to the local conductivity sigma = u^3/(12 eta) with
contact cells at sigma = 0.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from roughflow import fft
from roughflow.errors import InputError, plain_array, require_cell, require_field

from .effective_medium import local_conductivity

if TYPE_CHECKING:
    from numpy.typing import ArrayLike


def _require_varying(name: str, f: np.ndarray, cause: str = "") -> None:
    """:class:`InputError` where every value of ``f`` is the same (``cause``: why, for the
    message): tested on the values, not on the fluctuations, whose round-off (0.1 - mean
    of 0.1s is not 0) passed for a field and ended in "use a larger cell"."""
    if f.max() == f.min():
        raise InputError(f"{name} is constant ({float(f.flat[0]):.6g} in every cell"
                         f"{cause}): its autocorrelation, and any correlation length or "
                         "Peklenik number of it, is undefined")


def autocorrelation(field: ArrayLike) -> np.ndarray:
    """Normalised periodic autocorrelation C[ix, iy] of the fluctuations of ``field`` (C[0,0]=1);
    a boolean field (a contact mask: the pattern's own anisotropy) counts as 0 and 1."""
    raw = plain_array("field", field)
    f = require_field("field", raw.astype(np.float64) if raw.dtype.kind == "b" else raw)
    _require_varying("field", f)
    df = f - f.mean()
    c = fft.rfft2(df)
    acf = fft.irfft2(np.abs(c) ** 2, f.shape)
    if not acf[0, 0] > 0:
        raise InputError(f"field out of range: the squares of its fluctuations underflow "
                         f"(largest |f - mean| {float(np.abs(df).max()):.3g})")
    return acf / acf[0, 0]


def _crossing(profile: np.ndarray, step: float, level: float, axis: str) -> float:
    below = np.nonzero(profile <= level)[0]
    if below.size == 0:
        raise InputError(
            f"the autocorrelation along {axis} stays above {level:.3g} over half the cell: "
            "the correlation length is not resolved (use a larger cell)"
        )
    i = int(below[0])
    c0, c1 = profile[i - 1], profile[i]
    return step * ((i - 1) + (c0 - level) / (c0 - c1))


def correlation_lengths(
    field: ArrayLike, lx: float = 1.0, ly: float | None = None, *, level: float = math.exp(-1.0)
) -> tuple[float, float]:
    """Correlation lengths (xi_x, xi_y) of ``field[ix, iy]``: where C first drops to ``level``.

    ``lx``, ``ly``: the cell's side lengths; ``ly`` may be left out on a square grid only
    (:func:`roughflow.errors.require_cell`: a non-square grid is a square cell of
    rectangular pixels from :func:`roughflow.surface.generate` at gamma != 1, or square
    pixels from an array or scan). Only the first half of the periodic cell is searched
    along each axis.
    """
    acf = autocorrelation(field)
    nx, ny = acf.shape
    lx, ly = require_cell(lx, ly, acf.shape)
    if not 0.0 < level < 1.0:
        raise InputError(f"level must lie in (0, 1), got {level!r}")
    xi_x = _crossing(acf[: nx // 2 + 1, 0], lx / nx, level, "x")
    xi_y = _crossing(acf[0, : ny // 2 + 1], ly / ny, level, "y")
    return xi_x, xi_y


def peklenik_number(field: ArrayLike, lx: float = 1.0, ly: float | None = None, *,
                    level: float = math.exp(-1.0)) -> float:
    """xi_x / xi_y of ``field`` (> 1 when it is correlated longer along x)."""
    xi_x, xi_y = correlation_lengths(field, lx, ly, level=level)
    return xi_x / xi_y


def conductivity_peklenik(
    gap: ArrayLike, lx: float = 1.0, ly: float | None = None, *,
    contact: ArrayLike | None = None, eta: float = 1.0,
    level: float = math.exp(-1.0),
) -> float:
    """Conductivity Peklenik number: :func:`peklenik_number` of sigma = gap^3/(12 eta).

    Contact cells (gap = 0, or ``contact`` mask) have sigma = 0. Dimensionless. A constant
    sigma (every cell in contact, or one gap everywhere) has none: :class:`InputError`.
    """
    sigma = local_conductivity(require_field("gap", gap), eta, contact=contact)
    _require_varying("the local conductivity gap^3 / (12 eta)", sigma,
                     ": every cell is in contact" if sigma.flat[0] == 0 else
                     ": the gap is the same in every cell")
    return peklenik_number(sigma, lx, ly, level=level)
