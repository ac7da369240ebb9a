"""The small-load contact law a_c(p): where a load search starts and how it extrapolates.

Elastic contact. Persson theory gives a_c = erf(sqrt(2) p / (E* gbar)), whose small-load
slope is da_c/dp = sqrt(8/pi) = 1.60; GFMD simulations of self-affine surfaces find a slope
closer to 2 (docs/physics.md Sect. 6). We keep Persson's erf form and take its coefficient
from the simulated slope: a_c = erf(c p) has slope 2c/sqrt(pi), so slope 2 gives
c = sqrt(pi). Along a pressure ladder of one surface the form holds to a few per cent, which
is all a first guess needs.

Adhesive contact (the paper's case, docs/contact.md "Adhesion"): 10 % contact needs 1/8
and 40 % contact 1/4 of the elastic load. In between the load ratio is interpolated
linearly in a_c, outside it is held at the nearer end. Unlike the elastic law a_c(0) > 0,
so an adhesive extrapolation shifts the law through a solved state instead of scaling it.

Bearing model: the contact area is the control parameter itself.

Units: pressure in E* gbar.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from scipy.special import erf, erfinv

from roughflow.defaults import DEFAULT_MODEL, MAX_SEARCH_LOAD, MODELS
from roughflow.errors import InputError

#: Small-load slope da_c/dp of elastic contacts found in GFMD (Persson theory: 1.60).
ELASTIC_SLOPE = 2.0
#: c in a_c = erf(c p): 2c/sqrt(pi) = ELASTIC_SLOPE.
ERF_COEFFICIENT = 0.5 * math.sqrt(math.pi) * ELASTIC_SLOPE
#: The paper's adhesive case: (contact area, adhesive load / elastic load for that area).
PAPER_ADHESIVE_LOAD_RATIOS = ((0.1, 1 / 8), (0.4, 1 / 4))
#: Loads a search may try, per model (E* gbar; bearing: the area). Adhesive contacts are
#: searched from zero load up: under tension the contact can have no equilibrium
#: (pull-off), where a solve cannot converge.
LOAD_BOUNDS = {"elastic": (1e-6, MAX_SEARCH_LOAD), "adhesive": (0.0, MAX_SEARCH_LOAD),
               "bearing": (0.0, 1.0)}
# erfinv diverges at 0 and 1: targets are clipped this far inside
_AREA_MARGIN = 1e-6


def elastic_load_for_cells(cells: float, n_cells: int) -> float:
    """The load (E* gbar) at which the small-load law a_c = ELASTIC_SLOPE p puts ``cells``
    of a grid of ``n_cells`` in contact (linear: no clipping of tiny areas)."""
    return cells / n_cells / ELASTIC_SLOPE


def elastic_area(pressure: float) -> float:
    """a_c = erf(c p) of the elastic law at ``pressure`` (E* gbar): the contact area a cold
    solve expects (``contact.gfmd`` starts from the flat whose bearing area it is)."""
    return float(erf(ERF_COEFFICIENT * max(float(pressure), 0.0)))


def _adhesive_ratio(area: float) -> float:
    (a0, r0), (a1, r1) = PAPER_ADHESIVE_LOAD_RATIOS
    t = min(max((area - a0) / (a1 - a0), 0.0), 1.0)
    return r0 + t * (r1 - r0)


@dataclass(frozen=True)
class ContactLaw:
    """a_c(p) of one contact model (see the module docstring)."""

    model: str = DEFAULT_MODEL

    def __post_init__(self) -> None:
        if self.model not in MODELS:
            raise InputError(f"model must be one of {MODELS}, got {self.model!r}")

    @property
    def bounds(self) -> tuple[float, float]:
        """Loads a search may try (:data:`LOAD_BOUNDS`)."""
        return LOAD_BOUNDS[self.model]

    def control(self, area: float) -> float:
        """The load (bearing: the area) expected to give contact area ``area``."""
        if self.model == "bearing":
            return float(area)
        a = min(max(float(area), _AREA_MARGIN), 1.0 - _AREA_MARGIN)
        p = float(erfinv(a)) / ERF_COEFFICIENT
        return p * _adhesive_ratio(a) if self.model == "adhesive" else p

    def extrapolate(self, target: float, load: float, area: float) -> float:
        """Load for ``target`` from one solved state (``load``, ``area``) on this surface.

        Elastic: the law scaled through the solved state, load erfinv(target)/erfinv(area)
        (a factor 2 up or down where that is undefined); adhesive: the law shifted through
        it; bearing: the target itself.
        """
        if self.model == "bearing":
            return float(target)
        if self.model == "adhesive":
            return load + self.control(target) - self.control(area)
        t = min(max(float(target), _AREA_MARGIN), 1.0 - _AREA_MARGIN)
        if 0 < area < 1 and load > 0:
            return load * float(erfinv(t) / erfinv(area))
        return load * (2.0 if target > area else 0.5)

    def slope(self, load: float, area: float) -> float:
        """da_c/dp of the law made to pass through a solved state (``load``, ``area``) as
        :meth:`extrapolate` makes it (bearing: 1); nan where that is undefined (an area of 0
        or 1, the elastic law at zero load)."""
        if self.model == "bearing":
            return 1.0
        h = min(1e-4, 0.5 * area, 0.5 * (1.0 - area))
        if not h > 0 or (self.model == "elastic" and not load > 0):
            return math.nan
        dp = self.extrapolate(area + h, load, area) - self.extrapolate(area - h, load, area)
        return 2.0 * h / dp if dp > 0 else math.nan
