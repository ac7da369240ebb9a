"""Short-range adhesion (docs/physics.md Sect. 3.3): cosine attraction on a hard or harmonic wall.

Potential per unit area of the gap g (surface energy gamma_s, range rho):
    v(g) = -(gamma_s/2) (1 + cos(pi g / rho))        for 0 <= g <= rho
    v(g) = 0                                         for g > rho
    hard wall (``repulsion="hard"``, the default):   g >= 0
    harmonic (``repulsion="harmonic"``):             v(g) = -gamma_s + kappa g^2 / 2 for g < 0,
                                                     kappa = pi^2 gamma_s/(2 rho^2)
Maximum tension pi gamma_s / (2 rho) at g = rho/2. Units: gamma_s in E* L, rho in L.

Contact: a cell is in adhesive contact where its gap is below ``contact_within`` rho
(``defaults.ADHESION_CONTACT_WITHIN``: half the range on the hard wall, where the tension
peaks; the overlap g < 0 on the harmonic wall). A contact cell is closed: its gap in the
result is zero, for the percolation analysis and the flow alike.

The paper's adhesive case (Sect. 3.3: about 1 % contact at zero load, 10 % (40 %) contact at
1/8 (1/4) of the non-adhesive load of 10 % (40 %), and a mean gap about 10 % below the
non-adhesive one) is reproduced by the hard wall with gamma_s / v_ela^full =
``roughflow.defaults.ADHESION_SURFACE_ENERGY_RATIO`` and rho =
``ADHESION_RANGE_OVER_LAMBDA_S["hard"]`` lambda_s, calibrated on the surface of the paper's
Fig. 5 (H = 0.8, L/lambda_r = 16, eps_f = 1/16; docs/contact.md, "Adhesion"): the areas, and a
mean gap 12 % and 17 % below (11 % and 10 % counting the contact cells' physical gap). The harmonic
wall, calibrated the same way (rho = 0.42 lambda_s), gives the contact areas but a mean gap
32 % and 48 % below the non-adhesive one at 1/8 and 1/4 of those loads: cells in contact sink
into the soft wall. The paper's nominal mu_T = 2 and gamma_s / v_ela^full = 0.203, evaluated
with our R_c (:func:`curvature_radius`), give a range of 0.04 lambda_s and far too little
contact ([0.020, 0.024, 0.137] instead of [0.01, 0.10, 0.40] at 8 points per lambda_s,
harmonic wall): the paper's definitions of R_c and of the range must differ from ours by
factors we cannot recover from the text.

``dataclasses.replace`` keeps a resolved ``contact_within``: replacing the repulsion alone keeps
the old wall's criterion; give ``contact_within`` too.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from roughflow.defaults import ADHESION_CONTACT_WITHIN, ADHESION_REPULSION, ADHESION_REPULSIONS
from roughflow.errors import InputError, require_finite, require_positive

from .elastic import full_contact_energy


@dataclass(frozen=True)
class Adhesion:
    """Surface energy ``surface_energy`` (gamma_s, units E* L), range ``range`` (rho, L), the
    repulsion (``"hard"`` wall, the default, or ``"harmonic"``, kappa above) and the contact
    criterion: gap below ``contact_within`` rho (None: the repulsion's
    ``defaults.ADHESION_CONTACT_WITHIN``; 0: on the hard wall, or overlapping the harmonic
    one)."""

    surface_energy: float
    range: float
    repulsion: str = ADHESION_REPULSION
    contact_within: float | None = None

    def __post_init__(self) -> None:
        require_positive("surface_energy", self.surface_energy)
        require_positive("range", self.range)
        if self.repulsion not in ADHESION_REPULSIONS:
            raise InputError(f"repulsion must be one of {ADHESION_REPULSIONS}, got "
                             f"{self.repulsion!r}")
        if self.contact_within is None:
            object.__setattr__(self, "contact_within", ADHESION_CONTACT_WITHIN[self.repulsion])
        elif not 0.0 <= require_finite("contact_within", self.contact_within) <= 1.0:
            raise InputError(f"contact_within must lie in [0, 1] (a fraction of the range), "
                             f"got {self.contact_within!r}")

    @property
    def contact_gap(self) -> float:
        """Gaps below this count as contact (units of L; 0: overlap or on the wall)."""
        return self.contact_within * self.range

    def contact_mask(self, g: np.ndarray, touching: np.ndarray) -> np.ndarray:
        """Cells in adhesive contact: ``touching`` (overlap or on the wall, as the solver
        decides it) or a gap ``g`` below :attr:`contact_gap`."""
        return touching | (g < self.contact_gap) if self.contact_gap > 0 else touching

    @property
    def kappa(self) -> float:
        """Stiffness of the harmonic repulsion for g < 0 (smooth at g = 0)."""
        return math.pi**2 * self.surface_energy / (2 * self.range**2)

    @property
    def max_tension(self) -> float:
        return math.pi * self.surface_energy / (2 * self.range)

    def energy(self, g: np.ndarray) -> np.ndarray:
        gs, rho = self.surface_energy, self.range
        x = np.clip(g, 0.0, rho)
        v = -0.5 * gs * (1 + np.cos(np.pi * x / rho))
        return np.where(g < 0, -gs + 0.5 * self.kappa * g * g, v)

    def pressure(self, g: np.ndarray) -> np.ndarray:
        """Contact pressure -dv/dg: positive = repulsion, negative = adhesive tension."""
        gs, rho = self.surface_energy, self.range
        x = np.clip(g, 0.0, rho)
        t = -0.5 * gs * np.pi / rho * np.sin(np.pi * x / rho)
        return np.where(g < 0, -self.kappa * g, t)

    def physical_gap(self, gap: np.ndarray, contact: np.ndarray,
                     pressure: np.ndarray) -> np.ndarray:
        """The gaps of an adhesive result before its contact cells were closed (set to 0):
        each contact cell's gap from its contact pressure, inverting :meth:`pressure` on the
        branch of contact (tension rising from the wall to rho/2; the overlap -p/kappa on
        the harmonic wall; 0 for a hard-wall cell pressed on the wall). A warm start from
        the closed gaps loses the contact cells' tension: at zero load a restart from a
        converged state floated off to the detached state (a_c 0.59 -> 0), which is also
        an equilibrium there. Exact for ``contact_within`` <= 1/2; beyond, cells past the
        peak tension come back on the near side of it."""
        out = np.array(gap, dtype=np.float64)
        c = np.asarray(contact, bool)
        p = np.asarray(pressure, np.float64)[c]
        tension = np.clip(-p / self.max_tension, 0.0, 1.0)
        g = self.range / math.pi * np.arcsin(tension)
        if self.repulsion == "harmonic":
            g = np.where(p > 0, -p / self.kappa, g)
        out[c] = g
        return out

    def curvature(self, g: np.ndarray) -> np.ndarray:
        """d^2 v / dg^2 (negative in the attractive neck beyond rho/2)."""
        gs, rho = self.surface_energy, self.range
        x = np.clip(g, 0.0, rho)
        c = 0.5 * gs * (np.pi / rho) ** 2 * np.cos(np.pi * x / rho)
        return np.where(g < 0, self.kappa, np.where(g > rho, 0.0, c))


def curvature_radius(heights: np.ndarray, lx: float, ly: float) -> float:
    """R_c = 1/kappa_bar with kappa_bar^2 = <(laplacian h)^2>/4 (docs/physics.md Sect. 3.3)."""
    from roughflow import fft

    nx, ny = heights.shape
    c = fft.rfft2(heights) / (nx * ny)
    qx, qy = fft.wavevectors(nx, ny, lx, ly)
    w = fft.rfft_weights(ny)
    lap2 = float((w * (qx**2 + qy**2) ** 2 * np.abs(c) ** 2).sum())
    return 1.0 / math.sqrt(lap2 / 4.0)


def tabor_parameter(heights: np.ndarray, lx: float, ly: float, adhesion: Adhesion,
                    e_star: float = 1.0) -> float:
    """mu_T = (R_c gamma_s^2 / (E*^2 rho^3))^(1/3) with R_c from :func:`curvature_radius`
    (the rms curvature's radius: on a single sinusoid 2 sqrt(2) times its peak radius, so
    mu_T is 1.41 times the value with the peak radius)."""
    rc = curvature_radius(heights, lx, ly)
    return (rc * adhesion.surface_energy**2 / (e_star**2 * adhesion.range**3)) ** (1 / 3)


def adhesion_summary(heights: np.ndarray, lx: float, ly: float, adhesion: Adhesion) -> dict:
    """Tabor parameter, R_c, v_ela^full and gamma_s / v_ela^full for a surface."""
    v_full = full_contact_energy(heights, lx, ly)
    return {
        "tabor": tabor_parameter(heights, lx, ly, adhesion),
        "curvature_radius": curvature_radius(heights, lx, ly),
        "v_ela_full": v_full,
        "gamma_over_v_full": adhesion.surface_energy / v_full,
    }


def adhesion_for(heights: np.ndarray, lx: float, ly: float, *,
                 gamma_over_v_full: float, tabor: float | None = None,
                 range: float | None = None, repulsion: str = ADHESION_REPULSION,
                 contact_within: float | None = None) -> Adhesion:
    """Adhesion with gamma_s / v_ela^full = ``gamma_over_v_full`` on this surface and either a
    target Tabor parameter ``tabor`` or an explicit ``range`` rho (units of L); ``repulsion``
    and ``contact_within`` as :class:`Adhesion`.

    The paper's case: ``gamma_over_v_full=ADHESION_SURFACE_ENERGY_RATIO``,
    ``range=ADHESION_RANGE_OVER_LAMBDA_S[repulsion] * lambda_s``.
    """
    if repulsion not in ADHESION_REPULSIONS:  # before the surface's energy is computed
        raise InputError(f"repulsion must be one of {ADHESION_REPULSIONS}, got {repulsion!r}")
    if (tabor is None) == (range is None):
        raise InputError(f"give exactly one of tabor= and range=, got tabor={tabor!r}, "
                         f"range={range!r}")
    gs = require_positive("gamma_over_v_full", gamma_over_v_full) * full_contact_energy(
        heights, lx, ly)
    if range is not None:
        rho = require_positive("range", range)
    else:
        rc = curvature_radius(heights, lx, ly)
        rho = (rc * gs**2 / require_positive("tabor", tabor) ** 3) ** (1 / 3)
    return Adhesion(surface_energy=gs, range=rho, repulsion=repulsion,
                    contact_within=contact_within)
