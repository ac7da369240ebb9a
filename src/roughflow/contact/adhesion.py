"""Short-range adhesion (physics.md 3.3): harmonic repulsion plus cosine attraction.

Potential per unit area of the gap g (surface energy gamma_s, range rho):
    v(g) = -gamma_s + kappa g^2 / 2                  for g < 0,   kappa = pi^2 gamma_s/(2 rho^2)
    v(g) = -(gamma_s/2) (1 + cos(pi g / rho))        for 0 <= g <= rho
    v(g) = 0                                         for g > rho
Maximum tension pi gamma_s / (2 rho) at g = rho/2. Units: gamma_s in E* L, rho in L.

The harmonic branch is the default (as in the Mueser group's code); ``repulsion="hard"``
replaces it by a hard wall (gap >= 0), the kappa -> infinity limit. In the paper's case
kappa is ~14x the largest elastic stiffness of the grid, so the wall is nearly hard
anyway; on affordable grids, where the range must be a few grid spacings,
kappa = pi^2 gamma_s / (2 rho^2) becomes softer than the elastic grid stiffness and cells
sink into the wall, inflating the contact area (measured: a_c at fixed load *grew* when
gamma_s fell, at rho = 2 dx, 256^2). With the hard wall,
contact is gap = 0 exactly as in the elastic model.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from roughflow.errors import require_positive

from .elastic import full_contact_energy


@dataclass(frozen=True)
class Adhesion:
    """Surface energy ``surface_energy`` (gamma_s, units E* L), range ``range`` (rho, L) and
    the repulsion: ``"harmonic"`` (default, kappa above) or a ``"hard"`` wall."""

    surface_energy: float
    range: float
    repulsion: str = "harmonic"

    def __post_init__(self) -> None:
        require_positive("surface_energy", self.surface_energy)
        require_positive("range", self.range)
        if self.repulsion not in ("hard", "harmonic"):
            from roughflow.errors import InputError

            raise InputError(f"repulsion must be 'hard' or 'harmonic', got {self.repulsion!r}")

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

    def curvature(self, g: np.ndarray) -> np.ndarray:
        """d^2 v / dg^2 (negative in the attractive neck beyond rho/2)."""
        gs, rho = self.surface_energy, self.range
        x = np.clip(g, 0.0, rho)
        c = 0.5 * gs * (np.pi / rho) ** 2 * np.cos(np.pi * x / rho)
        return np.where(g < 0, self.kappa, np.where(g > rho, 0.0, c))


def curvature_radius(heights: np.ndarray, lx: float, ly: float) -> float:
    """R_c = 1/kappa_bar with kappa_bar^2 = <(laplacian h)^2>/4 (physics.md 3.3 [check])."""
    from roughflow import fft

    nx, ny = heights.shape
    c = fft.rfft2(heights) / (nx * ny)
    qx, qy = fft.wavevectors(nx, ny, lx, ly)
    w = fft.rfft_weights(ny)
    lap2 = float((w * (qx**2 + qy**2) ** 2 * np.abs(c) ** 2).sum())
    return 1.0 / math.sqrt(lap2 / 4.0)


def tabor_parameter(heights: np.ndarray, lx: float, ly: float, adhesion: Adhesion,
                    e_star: float = 1.0) -> float:
    """mu_T = (R_c gamma_s^2 / (E*^2 rho^3))^(1/3) with R_c from :func:`curvature_radius`."""
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


def adhesion_for(heights: np.ndarray, lx: float, ly: float, *, tabor: float,
                 gamma_over_v_full: float) -> Adhesion:
    """Adhesion with a target Tabor parameter and gamma_s / v_ela^full on this surface."""
    gs = gamma_over_v_full * full_contact_energy(heights, lx, ly)
    rc = curvature_radius(heights, lx, ly)
    rho = (rc * gs**2 / tabor**3) ** (1 / 3)
    return Adhesion(surface_energy=gs, range=rho)
