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
harmonic wall; an adhesive zone of 0.19 grid spacings, the grid's areas, now refused): the
paper's definitions of R_c and of the range must differ from ours by factors we cannot
recover from the text.

``dataclasses.replace`` keeps a resolved ``contact_within``: replacing the repulsion alone keeps
the old wall's criterion; give ``contact_within`` too.

Where the model holds (:func:`check_setup` before a solve, :func:`check_overlap` after it;
docs/contact.md "Adhesion", *Where the model holds*): the adhesive zone at a contact edge,
4 E* rho^2 / (pi^2 gamma_s) (:attr:`Adhesion.zone`), must span grid spacings, the contact
criterion's gap must stay below the surface's height range, and the harmonic wall, whose
kappa falls with gamma_s, must hold the load without the contact cells sinking into it by
more than the range on average.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np

from roughflow.defaults import ADHESION_CONTACT_WITHIN, ADHESION_REPULSION, ADHESION_REPULSIONS
from roughflow.errors import InputError, require_finite, require_positive

from .elastic import full_contact_energy, power_contact_energy

log = logging.getLogger(__name__)

#: The adhesive zone (:attr:`Adhesion.zone`) in grid spacings (the coarser of dx, dy) below
#: which the grid pins the contact line and a solve is refused, and below which a warning says
#: the contact area is not converged. Measured on Johnson's wavy surface (alpha 0.3; ranges
#: 0.025, 0.05 and 0.1 h0 fall on one curve in zone / dx), a_c above the converged one at zero
#: load: +0.12 at 0.58 spacings, +0.05 at 1.2, +0.014 at 2.3, +0.0025 at 4.7, +0.0005 at 9.3;
#: on rough surfaces the zero-load area was 3-10 times too large at 0.2-0.4 spacings, and the
#: contact added by the paper's nominal adhesion (0.05-0.2 spacings) grew 2.4-3.6 times from 2
#: to 8 points per lambda_s (docs/contact.md "Adhesion", *Where the model holds*).
ZONE_PINNED = 1.5
ZONE_RESOLVED = 9.0
#: The harmonic wall holds a load where its overlapping cells sink into it by at most this
#: many ranges on average. The paper's harmonic calibration stays below it (0.44, 0.56 and
#: 0.75 rho at zero load, p10/8 and p40/4 on the Fig. 5 surface); beyond it the load sinks
#: the body through the soft wall (a_c 0.64-1 where the elastic contact has 0.01-0.23,
#: weaker adhesion giving more contact). The mean overlap is at least load / kappa, so a load
#: above HARMONIC_MAX_OVERLAP kappa rho is refused before the solve.
HARMONIC_MAX_OVERLAP = 1.0


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

    @property
    def max_load(self) -> float:
        """The largest mean pressure this repulsion holds (E*): HARMONIC_MAX_OVERLAP kappa rho
        on the harmonic wall (above it the body sinks through the soft wall), none (inf) on
        the hard wall."""
        if self.repulsion != "harmonic":
            return math.inf
        return HARMONIC_MAX_OVERLAP * self.kappa * self.range

    @property
    def zone(self) -> float:
        """Width of the adhesive zone at a contact edge, E* gamma_s / max_tension^2 =
        4 E* rho^2 / (pi^2 gamma_s) (E* = 1; units of L): the grid must resolve it."""
        return 4.0 * self.range**2 / (math.pi**2 * self.surface_energy)

    def mean_overlap(self, pressure: np.ndarray) -> float:
        """Mean overlap of the cells overlapping the harmonic wall (from their pressures,
        -g = p / kappa); 0 on the hard wall or where none overlaps."""
        p = np.asarray(pressure, np.float64)
        pushed = p[p > 0]
        if self.repulsion != "harmonic" or pushed.size == 0:
            return 0.0
        return float(pushed.mean()) / self.kappa

    def energy(self, g: np.ndarray) -> np.ndarray:
        gs, rho = self.surface_energy, self.range
        x = np.clip(g, 0.0, rho)
        v = -0.5 * gs * (1 + np.cos(np.pi * x / rho))
        return np.where(g < 0, -gs + 0.5 * self.kappa * g * g, v)

    def pressure(self, g: np.ndarray) -> np.ndarray:
        """Contact pressure -dv/dg: positive = repulsion, negative = adhesive tension; exactly
        0 from the range rho on (sin(pi) is 1.2e-16, not 0, in floating point)."""
        rho = self.range
        x = np.clip(g, 0.0, rho)
        t = np.where(x < rho, -self.max_tension * np.sin(np.pi * x / rho), 0.0)
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
        return np.where(g < 0, self.kappa, np.where(g >= rho, 0.0, c))


def check_setup(adhesion: Adhesion, heights: np.ndarray, lx: float, ly: float,
                load: float, *, warn: bool = True) -> None:
    """Refuse (:class:`InputError`) an adhesive solve outside the model's validity before it
    starts, naming the value and the fix; with ``warn``, log a warning where the adhesive
    zone is under-resolved (module constants above; docs/contact.md "Adhesion")."""
    zone = check_zone(adhesion, heights.shape, lx, ly)
    what = f"surface energy {adhesion.surface_energy:.4g}, range {adhesion.range:.4g}"
    height_range = float(np.max(heights) - np.min(heights))
    if adhesion.contact_gap >= height_range:
        raise InputError(
            f"the contact criterion counts gaps below contact_within x range = "
            f"{adhesion.contact_gap:.4g} ({what}), at least the surface's height range "
            f"{height_range:.4g}: wherever the surfaces touch every cell would count as "
            f"contact (a_c = 1 whatever the load); give a range below "
            f"{height_range / adhesion.contact_within:.4g} (short against the roughness) or "
            "contact_within=0 (contact on the wall only)")
    if load > adhesion.max_load:
        raise InputError(
            f"the harmonic wall (kappa = pi^2 gamma_s / (2 rho^2) = {adhesion.kappa:.4g}; "
            f"{what}) cannot hold the load {load:.4g}: its overlapping cells would sink into it "
            f"by at least load / kappa = {load / adhesion.kappa / adhesion.range:.3g} ranges on "
            f"average (at most {HARMONIC_MAX_OVERLAP:g}: a soft wall, not a contact); the load "
            f"may be at most {adhesion.max_load:.4g}, or "
            "use repulsion='hard' (the default), or a larger surface energy")
    if warn and zone < ZONE_RESOLVED:
        log.warning("the adhesive zone 4 rho^2 / (pi^2 gamma_s) = %.3g (%s) spans %.3g grid "
                    "spacings, under the %g that converge the contact area to 0.001 (at 2.3 "
                    "spacings it is about 0.015 too large): use a larger range or a finer grid",
                    adhesion.zone, what, zone, ZONE_RESOLVED)


def check_zone(adhesion: Adhesion, shape: tuple[int, int], lx: float, ly: float) -> float:
    """The adhesive zone in grid spacings of a ``shape`` grid on an ``lx`` x ``ly`` cell;
    :class:`InputError` where the grid pins the contact line (below ``ZONE_PINNED``)."""
    nx, ny = shape
    spacing = max(lx / nx, ly / ny)
    zone = adhesion.zone / spacing
    what = f"surface energy {adhesion.surface_energy:.4g}, range {adhesion.range:.4g}"
    if zone < ZONE_PINNED:
        raise InputError(
            f"the adhesive zone 4 rho^2 / (pi^2 gamma_s) = {adhesion.zone:.3g} ({what}) spans "
            f"{zone:.3g} grid spacings of {spacing:.3g}, below {ZONE_PINNED:g}: the grid pins "
            f"the contact line and the contact area is the grid's; give a range of at least "
            f"{_range_for(adhesion, ZONE_PINNED * spacing):.3g} or a grid at least "
            f"{ZONE_PINNED / zone:.3g} times finer (about {ZONE_RESOLVED:g} spacings "
            "converge a_c to 0.001)")
    return zone


def check_overlap(adhesion: Adhesion, load: float, pressure: np.ndarray) -> None:
    """Refuse (:class:`InputError`) a solved harmonic-wall state whose overlapping cells sank
    into the wall by more than ``HARMONIC_MAX_OVERLAP`` ranges on average (see
    :func:`check_setup`; measured after the solve, where the load alone did not show it)."""
    overlap = adhesion.mean_overlap(pressure) / adhesion.range
    if overlap > HARMONIC_MAX_OVERLAP:
        raise InputError(
            f"at the load {load:.4g} the cells in contact sank into the harmonic wall (kappa = "
            f"{adhesion.kappa:.4g}; surface energy {adhesion.surface_energy:.4g}, range "
            f"{adhesion.range:.4g}) by {overlap:.3g} ranges on average, more than "
            f"{HARMONIC_MAX_OVERLAP:g}: the wall is too soft for the load (kappa falls with "
            "the surface energy) and the contact area is the overlap's, not a contact's; use "
            "repulsion='hard' (the default), a larger surface energy or a smaller load")


def _range_for(adhesion: Adhesion, zone: float) -> float:
    """The range whose adhesive zone is ``zone`` at this surface energy."""
    return math.pi * math.sqrt(zone * adhesion.surface_energy) / 2.0


def curvature_radius(heights: np.ndarray, lx: float, ly: float) -> float:
    """R_c = 1/kappa_bar with kappa_bar^2 = <(laplacian h)^2>/4 (docs/physics.md Sect. 3.3)."""
    from roughflow import fft

    nx, ny = heights.shape
    c = fft.rfft2(heights) / (nx * ny)
    qx, qy = fft.wavevectors(nx, ny, lx, ly)
    w = fft.rfft_weights(ny)
    return power_curvature_radius(qx**2 + qy**2, w * np.abs(c) ** 2)


def power_curvature_radius(q_squared: np.ndarray, power: np.ndarray) -> float:
    """R_c of :func:`curvature_radius` from the modes' |q|^2 and power w |h~(q)|^2."""
    lap2 = float((q_squared**2 * power).sum())
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
    return _adhesion(lambda: full_contact_energy(heights, lx, ly),
                     lambda: curvature_radius(heights, lx, ly),
                     gamma_over_v_full=gamma_over_v_full, tabor=tabor, range=range,
                     repulsion=repulsion, contact_within=contact_within)


def adhesion_for_power(q: np.ndarray, power: np.ndarray, *, gamma_over_v_full: float,
                       tabor: float | None = None, range: float | None = None,
                       repulsion: str = ADHESION_REPULSION,
                       contact_within: float | None = None) -> Adhesion:
    """:func:`adhesion_for` from the modes' |q| and power (w |h~(q)|^2) of a surface: of
    every surface of a spec (:func:`roughflow.surface.spec_power`) before any is made."""
    return _adhesion(lambda: power_contact_energy(q, power),
                     lambda: power_curvature_radius(q * q, power),
                     gamma_over_v_full=gamma_over_v_full, tabor=tabor, range=range,
                     repulsion=repulsion, contact_within=contact_within)


def _adhesion(v_full, radius, *, gamma_over_v_full, tabor, range, repulsion,
              contact_within) -> Adhesion:
    """The Adhesion of :func:`adhesion_for`, ``v_full`` and ``radius`` computing the
    surface's v_ela^full and R_c once the arguments are checked."""
    if repulsion not in ADHESION_REPULSIONS:  # before the surface's energy is computed
        raise InputError(f"repulsion must be one of {ADHESION_REPULSIONS}, got {repulsion!r}")
    if (tabor is None) == (range is None):
        raise InputError(f"give exactly one of tabor= and range=, got tabor={tabor!r}, "
                         f"range={range!r}")
    gs = require_positive("gamma_over_v_full", gamma_over_v_full) * v_full()
    if range is not None:
        rho = require_positive("range", range)
    else:
        rho = (radius() * gs**2 / require_positive("tabor", tabor) ** 3) ** (1 / 3)
    return Adhesion(surface_energy=gs, range=rho, repulsion=repulsion,
                    contact_within=contact_within)
