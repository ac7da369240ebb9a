"""Bearing-area (overlap) model, docs/physics.md Sect. 3.4: no elasticity, gap = max(d - h, 0)."""

from __future__ import annotations

import numpy as np

from ._result import ContactResult


def solve_bearing(heights: np.ndarray, area_fraction: float) -> ContactResult:
    """Flat plane at height d such that the top ``area_fraction`` of the grid points are in
    contact (h >= d); gap = max(d - h, 0). a_c = round(a N)/N exactly.

    d is placed on the highest non-contact height (ties broken by order), so the
    contact points are exactly the k highest and their gap is 0.
    """
    h = heights
    n = h.size
    k = int(round(area_fraction * n))
    flat = h.ravel()
    contact = np.zeros(n, dtype=bool)
    if k >= n:
        d = float(flat.max())
        contact[:] = True
    elif k == 0:
        d = float(flat.max())
    else:
        order = np.argpartition(-flat, k)
        top = order[:k]
        contact[top] = True
        d = float(flat[order[k]])  # highest non-contact height
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
