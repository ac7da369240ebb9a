"""Bearing-area (overlap) model, docs/physics.md Sect. 3.4: no elasticity, gap = max(d - h, 0)."""

from __future__ import annotations

import numpy as np

from ._result import ContactResult


def solve_bearing(heights: np.ndarray, area_fraction: float) -> ContactResult:
    """Flat plane at height d such that the top ``area_fraction`` of the grid points are in
    contact (h >= d); gap = max(d - h, 0). a_c = round(a N)/N exactly.

    d lies halfway between the lowest contact height and the highest non-contact one, so
    the contact points are exactly the k highest (ties broken by order), their gap is 0 and
    every other point's gap is positive (unless it ties with a contact height): the mask
    and the gap agree on what is open, for percolation and flow alike (a plane on the
    highest non-contact height would give that point gap 0 without contact; at a threshold
    state it is the critical point, and the flow would see no path where the fluid
    percolates). At full contact d is the lowest height; without contact the plane touches
    the highest point.
    """
    h = heights
    n = h.size
    k = int(round(area_fraction * n))
    flat = h.ravel()
    contact = np.zeros(n, dtype=bool)
    if k >= n:
        d = float(flat.min())
        contact[:] = True
    elif k == 0:
        d = float(flat.max())
    else:
        # positions k - 1 and k sorted: the lowest contact and highest non-contact heights
        order = np.argpartition(-flat, (k - 1, k))
        contact[order[:k]] = True
        d = 0.5 * (float(flat[order[k - 1]]) + float(flat[order[k]]))
    gap = np.maximum(d - h, 0.0)
    mask = contact.reshape(h.shape)
    gap[mask] = 0.0
    return ContactResult(
        gap=gap,
        contact_pressure=np.zeros_like(h),
        contact=mask,
        area_fraction=float(mask.mean()),
        mean_gap=float(gap.mean()),
        pressure=float("nan"),
        iterations=0,
        residual=0.0,
        converged=True,
        model="bearing",
        method="overlap",
        separation=d - float(h.mean()),
    )
