"""Cheaper accuracy for the contact area: perimeter correction and Richardson extrapolation.

The relative contact area a_c of a discretised elastic contact converges only to first
order in the grid spacing: a cell whose centre lies in contact is counted whole, and the
discrete solution over-predicts contact in a band along every contact line whose depth is
a fixed fraction of the grid spacing normal to the line. Two remedies (docs/accuracy.md has
the measurements):

- :func:`perimeter_corrected_area`: a_c - c * (contact/non-contact cell faces) / (cells).
  Each face carries a band c * (spacing normal to the face) deep and one face long, i.e.
  c cell areas, whatever the cell's aspect ratio: on the gamma:1 rectangular cells of
  anisotropic sweep surfaces a face normal to x is dy long and dx deep. (Weighting the
  faces by their length times the geometric-mean spacing instead under-weights x-normal
  faces by 1/sqrt(gamma) and over-weights y-normal ones by sqrt(gamma): on gamma = 2 and 4
  surfaces the constant fitted that way drifts with gamma while the per-face one does not;
  docs/accuracy.md.) ``c`` is fitted to converged references with
  :func:`fit_perimeter_constant`; :data:`PERIMETER_C` is the value measured by
  ``roughflow accuracy`` (:mod:`roughflow.convergence`) on the default sweep surfaces
  (elastic, H = 0.8, eps_f = 1/16). Yastrebov, Anciaux & Molinari (Tribol. Int. 114 (2017)
  161) derived a correction of the same form from the geometry of the contact edge.
- :func:`richardson`: extrapolation of a first-order quantity from two resolutions,
  a_inf = (r^p a_fine - a_coarse) / (r^p - 1).

Units: lengths in L (cell side), areas as fractions of the cell area.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from roughflow.errors import (
    InputError,
    require_cell,
    require_finite,
    require_mask,
    require_positive,
)

if TYPE_CHECKING:
    from collections.abc import Hashable, Iterable

    from numpy.typing import ArrayLike

__all__ = ["PERIMETER_C", "contact_faces", "contact_line_length", "perimeter_term",
           "perimeter_corrected_area", "richardson", "PerimeterFit", "fit_perimeter_constant"]

#: Perimeter constant c fitted by ``roughflow accuracy`` (elastic contact, default
#: sweep surfaces, 4 to 16 points per lambda_s; docs/accuracy.md): the misclassified area
#: per contact/non-contact face, in cell areas. Fitted on square cells (gamma = 1) and
#: confirmed per face on the rectangular cells of gamma = 2 and 4 surfaces.
#: Faces are counted along the grid axes (Manhattan length, on average 4/pi times the
#: Euclidean length).
PERIMETER_C = 0.105


def contact_faces(contact: ArrayLike) -> tuple[int, int]:
    """Number of contact/non-contact cell faces normal to x and normal to y (periodic)."""
    m = require_mask("contact mask", contact)
    fx = int(np.count_nonzero(m != np.roll(m, -1, axis=0)))
    fy = int(np.count_nonzero(m != np.roll(m, -1, axis=1)))
    return fx, fy


def contact_line_length(contact: ArrayLike, lx: float = 1.0, ly: float | None = None) -> float:
    """Length of the contact line (units of L) counted along cell faces.

    A face between cells ix and ix+1 has length dy; one between iy and iy+1 has length dx.
    """
    m = require_mask("contact mask", contact)
    lx, ly = require_cell(lx, ly, m.shape)
    fx, fy = contact_faces(m)
    nx, ny = m.shape
    return fx * ly / ny + fy * lx / nx


def perimeter_term(contact: ArrayLike) -> float:
    """Contact/non-contact cell faces per cell (dimensionless, periodic).

    The quantity multiplied by ``c`` in :func:`perimeter_corrected_area`: each face stands
    for a misclassified band of one cell area (face length times the spacing normal to it),
    so the term is (faces normal to x + faces normal to y) / (number of cells) on square
    and rectangular cells alike. On square cells it equals the contact-line length (counted
    along faces) times the spacing over the cell area.
    """
    m = require_mask("contact mask", contact)
    fx, fy = contact_faces(m)
    return (fx + fy) / m.size


def perimeter_corrected_area(contact: ArrayLike, *, c: float = PERIMETER_C) -> float:
    """Relative contact area corrected for the first-order grid bias: a_c - c * faces / cells.

    ``contact``: boolean mask ``[ix, iy]`` (any cell aspect ratio); ``c``: the perimeter
    constant (default :data:`PERIMETER_C`, measured); returns a fraction of the cell area.
    """
    m = require_mask("contact mask", contact)
    c = require_finite("c", c)
    return float(m.mean()) - c * perimeter_term(m)


def richardson(coarse: float, fine: float, *, ratio: float = 2.0, order: float = 1.0) -> float:
    """Richardson extrapolation to zero grid spacing from two resolutions.

    ``fine`` was computed with a spacing ``ratio`` times smaller than ``coarse``; the error
    is assumed to be C h^order. Returns (r^p fine - coarse) / (r^p - 1).
    """
    coarse = require_finite("coarse", coarse)
    fine = require_finite("fine", fine)
    ratio = require_positive("ratio", ratio)
    order = require_positive("order", order)
    if ratio == 1.0:
        raise InputError("ratio must differ from 1")
    k = ratio**order
    return (k * fine - coarse) / (k - 1.0)


@dataclass(frozen=True)
class PerimeterFit:
    """Least-squares fit of a(h) = a_inf[group] + c * P h over resolutions.

    ``c``: shared perimeter constant; ``a_inf``: extrapolated area per group;
    ``rms``: rms residual of the fit; ``n``: number of data points.
    """

    c: float
    a_inf: dict
    rms: float
    n: int


def fit_perimeter_constant(groups: Iterable[Hashable], areas: ArrayLike,
                           perimeter_terms: ArrayLike) -> PerimeterFit:
    """Fit a shared c in a_c = a_inf(group) + c * perimeter_term over all points.

    ``groups``: labels identifying the same physical state (same surface and load) at
    different resolutions; ``areas``: measured a_c; ``perimeter_terms``: values of
    :func:`perimeter_term` for the same solves. Needs at least two resolutions per group.
    """
    g = list(groups)
    a = np.asarray(areas, dtype=np.float64)
    t = np.asarray(perimeter_terms, dtype=np.float64)
    if not (len(g) == a.size == t.size) or a.ndim != 1:
        raise InputError(
            f"groups, areas and perimeter_terms must have equal length, got "
            f"{len(g)}, {a.size}, {t.size}"
        )
    if not (np.isfinite(a).all() and np.isfinite(t).all()):
        raise InputError("areas and perimeter_terms must be finite")
    labels = sorted(set(g), key=str)
    if len(labels) == 0 or a.size < len(labels) + 1:
        raise InputError(f"need at least two resolutions per group, got {a.size} points "
                         f"in {len(labels)} groups")
    idx = {lab: i for i, lab in enumerate(labels)}
    design = np.zeros((a.size, len(labels) + 1))
    for k, lab in enumerate(g):
        design[k, idx[lab]] = 1.0
    design[:, -1] = t
    coef, *_ = np.linalg.lstsq(design, a, rcond=None)
    resid = a - design @ coef
    return PerimeterFit(
        c=float(coef[-1]),
        a_inf={lab: float(coef[idx[lab]]) for lab in labels},
        rms=float(np.sqrt(np.mean(resid**2))),
        n=int(a.size),
    )
