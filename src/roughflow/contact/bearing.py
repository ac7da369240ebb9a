"""Bearing-area (overlap) model, docs/physics.md Sect. 3.4: no elasticity, gap = max(d - h, 0)."""

from __future__ import annotations

import logging

import numpy as np

from ._result import ContactResult

log = logging.getLogger(__name__)


def solve_bearing(heights: np.ndarray, area_fraction: float, *,
                  warn_ties: bool = True) -> ContactResult:
    """Flat plane at height d such that the top ``area_fraction`` of the grid points are in
    contact (h >= d); gap = max(d - h, 0). a_c = round(a N)/N exactly on heights without ties.

    d lies halfway between the lowest contact height and the highest non-contact one, so
    the contact points are exactly the k highest, their gap is 0 and every other point's
    gap is positive: the mask and the gap agree on what is open, for percolation and flow
    alike (a plane on the highest non-contact height would give that point gap 0 without
    contact; at a threshold state it is the critical point, and the flow would see no path
    where the fluid percolates). Where the k-th highest height is shared by cells beyond
    the k-th (a quantized scan), no plane separates them: the whole tie group is in contact
    and a_c is the area it then has, above round(a N)/N (logged as a warning), never a
    choice among equal heights. At full contact d is the lowest height; without contact
    it lies above the highest point by half that point's step to the next height (every
    gap positive; a flat surface's plane touches it). ``warn_ties=False`` leaves the warning out (a
    threshold search, which judges the tie groups inside its brackets itself).
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
        # above the highest point by half its step to the next height, as between contact
        # and non-contact above: a plane on it left that point gap 0 without contact
        top = float(flat.max())
        below = flat[flat < top]
        d = top + 0.5 * (top - float(below.max())) if below.size else top
    else:
        # positions k - 1 and k sorted: the lowest contact and highest non-contact heights
        order = np.argpartition(-flat, (k - 1, k))
        low, high = float(flat[order[k - 1]]), float(flat[order[k]])
        if high < low:
            contact[order[:k]] = True
            d = 0.5 * (low + high)
        else:  # the plane cuts a tie group: all of it touches
            contact = flat >= low
            below = flat[~contact]
            if below.size:
                d = 0.5 * (low + float(below.max()))
            else:
                d = low
            if warn_ties:
                log.warning("bearing contact at area_fraction=%.6g: %d cells share the height "
                            "%r, which the plane cuts; all are in contact, a_c = %.6g",
                            area_fraction, int(np.count_nonzero(flat == low)), low,
                            np.count_nonzero(contact) / n)
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
