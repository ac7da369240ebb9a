"""Exact spanning threshold of a growing open set: one union-find pass (no bisection).

Used for the bearing model's exact threshold (:func:`bearing_bracket`: cells open in order
of height) and for the first-order prediction of a_c* from a solved elastic state
(:func:`predicted_thresholds` over :func:`open_first_order`).

Cells are opened one by one in a given order (e.g. by increasing height for the bearing
model); after each addition the new cell is joined to its open 4-neighbours (open
boundaries along ``axis``, periodic across it) and each root remembers whether its cluster
touches the first and/or the last slab along ``axis``. The first cell that links both ends
gives the critical number of open cells. Compiled with numba; O(N alpha(N)).
"""

from __future__ import annotations

from typing import NamedTuple

import numba
import numpy as np

from .labels import check_axis

_LOW, _HIGH = 1, 2


@numba.njit(cache=True)
def _find(parent, x):
    while parent[x] != x:
        parent[x] = parent[parent[x]]  # path halving
        x = parent[x]
    return x


@numba.njit(cache=True)
def _critical_count(order, nx, ny, axis):
    n = nx * ny
    parent = np.full(n, -1, dtype=np.int32)  # int32 halves the memory traffic
    size = np.zeros(n, dtype=np.int32)
    flags = np.zeros(n, dtype=np.int8)
    nlen = nx if axis == 0 else ny
    for k in range(order.size):
        c = order[k]
        ix = c // ny
        iy = c - ix * ny
        parent[c] = c
        size[c] = 1
        pos = ix if axis == 0 else iy
        f = 0
        if pos == 0:
            f |= _LOW
        if pos == nlen - 1:
            f |= _HIGH
        flags[c] = f
        root = c
        for d in range(4):
            jx = ix
            jy = iy
            if d == 0:
                jx = ix + 1
            elif d == 1:
                jx = ix - 1
            elif d == 2:
                jy = iy + 1
            else:
                jy = iy - 1
            if axis == 0:  # open along x, periodic in y
                if jx < 0 or jx >= nx:
                    continue
                jy = jy % ny
            else:  # open along y, periodic in x
                if jy < 0 or jy >= ny:
                    continue
                jx = jx % nx
            nb = jx * ny + jy
            if parent[nb] < 0:
                continue
            r = _find(parent, nb)
            if r == root:
                continue
            if size[r] > size[root]:
                r, root = root, r
            parent[r] = root
            size[root] += size[r]
            flags[root] |= flags[r]
        if flags[root] == _LOW | _HIGH:
            return k + 1
    return -1


def critical_open_count(order: np.ndarray, shape: tuple[int, int], axis: int) -> int:
    """Smallest k such that the first k cells of ``order`` (flat C-order indices into an
    array of ``shape``) form an open set that spans along ``axis`` (4-connected, open
    boundaries along ``axis``, periodic across). Returns -1 if even all cells do not span
    (only possible when ``order`` is not a permutation of all cells).
    """
    ax = check_axis(axis)
    nx, ny = (int(s) for s in shape)
    if nx * ny >= 2**31:
        raise ValueError(f"grid {nx} x {ny} too large for the int32 union-find")
    order = np.ascontiguousarray(order, dtype=np.int64)
    if order.size and (order.min() < 0 or order.max() >= nx * ny):
        raise ValueError("order holds indices outside the grid")
    return int(_critical_count(order, nx, ny, ax))



class BearingBracket(NamedTuple):
    """Bearing-model threshold along one axis: the fluid spans at contact area ``a_lo`` and
    not at ``a_hi``; ``tied`` cells share the critical ``height`` (1 = exact to one cell)."""

    a_lo: float
    a_hi: float
    tied: int
    height: float


def bearing_bracket(heights: np.ndarray, axis: int) -> BearingBracket:
    """Exact fluid percolation threshold of the bearing model along ``axis``.

    Contact is the top fraction of heights, so the open set grows from the lowest cell up;
    the first cell whose opening makes the fluid span fixes the threshold. Cells of equal
    height open together, so the bracket widens over their tie group.
    """
    flat = np.asarray(heights, dtype=np.float64).ravel()
    n = flat.size
    order = np.argsort(flat, kind="stable")
    hs = flat[order]
    k = critical_open_count(order, heights.shape, axis)
    i0 = int(np.searchsorted(hs, hs[k - 1], side="left"))
    i1 = int(np.searchsorted(hs, hs[k - 1], side="right"))
    return BearingBracket(a_lo=1.0 - i1 / n, a_hi=1.0 - i0 / n, tied=i1 - i0,
                          height=float(hs[k - 1]))


def open_first_order(gap: np.ndarray, contact: np.ndarray, pressure: np.ndarray) -> np.ndarray:
    """Flat indices of a contact state from the most open to the most closed cell: open cells
    by decreasing gap, then contact cells by increasing contact pressure."""
    flat_c = np.asarray(contact, dtype=bool).ravel()
    idx_open = np.flatnonzero(~flat_c)
    idx_cont = np.flatnonzero(flat_c)
    o = idx_open[np.argsort(-gap.ravel()[idx_open])]
    c = idx_cont[np.argsort(pressure.ravel()[idx_cont])]
    return np.concatenate([o, c])


def predicted_thresholds(order: np.ndarray, shape: tuple[int, int],
                         axes=(0, 1)) -> dict[int, float]:
    """Predicted a_c* per axis: the contact area at which the open set built in ``order``
    first spans, taken at the middle of the critical cell (exact for the bearing model with
    heights as the order, first order for an elastic state with :func:`open_first_order`)."""
    n = order.size
    return {ax: 1.0 - (critical_open_count(order, shape, ax) - 0.5) / n for ax in axes}
