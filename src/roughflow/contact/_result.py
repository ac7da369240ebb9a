"""Results of contact solves: the raw output of one method and the public result."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from roughflow._repr import summary_repr


@dataclass(frozen=True, eq=False)
class SolverOutput:
    """What a contact method (``gfmd``, ``polonsky_keer``) returns; ``solve`` wraps it.

    pressure: local contact pressure (negative values are adhesive tension);
    gap: interfacial separation >= 0; contact: boolean contact mask;
    separation: mean plane of the elastic body relative to the surface's mean plane;
    iterations, residual, converged: the method's diagnostics (residual in units of the
    rms height, see ``roughflow.contact.solve``);
    plastic, plastic_depth: a solve with a hardness (``polonsky_keer(hardness=)``) only,
    else None: the mask of the cells at the cap and their plastic depth (0 elsewhere).
    """

    __repr__ = summary_repr

    pressure: np.ndarray
    gap: np.ndarray
    contact: np.ndarray
    separation: float
    iterations: int
    residual: float
    converged: bool
    plastic: np.ndarray | None = None
    plastic_depth: np.ndarray | None = None


@dataclass(frozen=True, eq=False)
class ContactResult:
    """Solution of a rigid rough surface pressed onto a flat elastic half-space.

    Units: lengths in L (cell side), pressures in E* (E* = 1; the generated surfaces'
    rms gradient gbar is 1, so their pressures are also in E* gbar). Fields are indexed
    ``[ix, iy]``.

    gap: interfacial separation u_g(r) >= 0 (zero in contact).
    contact_pressure: local contact pressure (>= 0 for repulsive models; negative values
        are adhesive tension); its mean equals ``pressure`` to round-off for cg, to the
        solve's ``tol`` for gfmd, whose residual includes the load imbalance: within
        ``tol`` relative on the hard wall (measured up to 9.4e-3 at tol 1e-2, 9e-7 at
        1e-6), within ``tol`` k_min rms(h) with adhesion (:func:`roughflow.contact.solve`, ``tol``).
    contact: boolean contact mask (gap == 0 for the elastic and bearing models; for the
        adhesive model the adhesion's ``contact_mask``: a gap below half the range on the
        hard wall, overlap on the harmonic one; the gap is set to zero there).
    area_fraction: relative contact area a_c = contact.mean().
    mean_gap: mean of ``gap`` over the cell.
    pressure: applied mean pressure (load per area); NaN for the bearing model, which has
        none (:meth:`scalars` leaves it out there).
    iterations, residual, converged: solver diagnostics (residual as defined by the
        method; see ``roughflow.contact.solve``).
    model, method: what produced the result.
    separation: position of the elastic body's mean plane relative to the surface's mean
        plane (the "d" of the bearing model).
    hardness: the pressure cap H of an elastic-perfectly-plastic solve (``solve(...,
        hardness=)``, units of ``pressure``), else None; then also
    plastic: boolean mask of the plastic cells (contact_pressure == hardness; part of
        ``contact``, gap 0);
    plastic_depth: how far the rigid surface penetrates the elastic body's surface there
        (units L, >= 0; 0 off the plastic cells): the permanent indentation the model
        leaves out of the elastic field;
    plastic_fraction: plastic.mean() (NaN without a hardness).

    Warm starts (``solve(..., init=result)``) use ``contact_pressure`` (cg) or
    ``heights + gap`` (gfmd), so any result on the same surface can seed any method.
    """

    __repr__ = summary_repr

    gap: np.ndarray
    contact_pressure: np.ndarray
    contact: np.ndarray
    area_fraction: float
    mean_gap: float
    pressure: float
    iterations: int
    residual: float
    converged: bool
    model: str
    method: str
    separation: float = float("nan")
    hardness: float | None = None
    plastic: np.ndarray | None = None
    plastic_depth: np.ndarray | None = None
    plastic_fraction: float = float("nan")

    def scalars(self) -> dict:
        """Every scalar field, for netCDF attributes; no ``pressure`` for the bearing model
        (a rigid cut, no load: a NaN there read as a failed solve), ``hardness`` and
        ``plastic_fraction`` only for a solve with a hardness."""
        out = {
            "area_fraction": self.area_fraction,
            "mean_gap": self.mean_gap,
            "pressure": self.pressure,
            "iterations": self.iterations,
            "residual": self.residual,
            "converged": self.converged,
            "model": self.model,
            "method": self.method,
            "separation": self.separation,
        }
        if self.model == "bearing":
            del out["pressure"]
        if self.hardness is not None:
            out["hardness"] = self.hardness
            out["plastic_fraction"] = self.plastic_fraction
        return out
