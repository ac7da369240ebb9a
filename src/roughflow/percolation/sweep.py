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

import math
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from roughflow._jit import njit
from roughflow.errors import InputError, require_field

from .labels import check_axis

if TYPE_CHECKING:
    from collections.abc import Iterable

_LOW, _HIGH = 1, 2


@njit(cache=True)
def _find(parent, x):
    while parent[x] != x:
        parent[x] = parent[parent[x]]  # path halving
        x = parent[x]
    return x


@njit(cache=True)
def _link(parent, size, flags, a, b):
    """Union of the clusters of cells ``a`` and ``b``; returns the new root."""
    ra = _find(parent, a)
    rb = _find(parent, b)
    if ra == rb:
        return ra
    if size[ra] < size[rb]:
        ra, rb = rb, ra
    parent[rb] = ra
    size[ra] += size[rb]
    flags[ra] |= flags[rb]
    return ra


@njit(cache=True)
def _open(c, pos, nlen, parent, size, flags):
    """Open cell ``c`` as a cluster of its own; ``pos``: its index along the axis of
    ``nlen`` cells, for the flags "touches the first / last slab"."""
    parent[c] = c
    size[c] = 1
    f = 0
    if pos == 0:
        f |= _LOW
    if pos == nlen - 1:
        f |= _HIGH
    flags[c] = f


@njit(cache=True)
def _sweep(cells, nx, ny, axis, parent, size, flags):
    """Open ``cells`` in turn on the union-find state (parent < 0: closed); returns the
    position + 1 of the cell whose opening first links both ends along ``axis``, or -1."""
    nlen = nx if axis == 0 else ny
    for k in range(cells.size):
        c = cells[k]
        ix = c // ny
        iy = c - ix * ny
        _open(c, ix if axis == 0 else iy, nlen, parent, size, flags)
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
            if parent[nb] >= 0:
                root = _link(parent, size, flags, nb, root)
        if flags[root] == _LOW | _HIGH:
            return k + 1
    return -1


def _union_find_state(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    # int32 halves the memory traffic
    return (np.full(n, -1, dtype=np.int32), np.zeros(n, dtype=np.int32),
            np.zeros(n, dtype=np.int8))


class SweepWork(NamedTuple):
    """Arrays of :func:`critical_open_count_by_key` on ``n`` cells, reused from call to call
    by a caller that sweeps many keys of one grid (the threshold search: fresh memory costs
    about 20 ms per 8 MB on our machines, docs/contact.md "Workspace"): the union-find state
    (parent, size, flags) and the indices of the cells collected for a chunk (``nxt``)."""

    parent: np.ndarray
    size: np.ndarray
    flags: np.ndarray
    nxt: np.ndarray


def sweep_work(n: int) -> SweepWork:
    """An empty :class:`SweepWork` for ``n`` cells (13 bytes a cell)."""
    return SweepWork(np.empty(n, dtype=np.int32), np.empty(n, dtype=np.int32),
                     np.empty(n, dtype=np.int8), np.empty(n, dtype=np.int32))


def _reset(work: SweepWork) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    work.parent.fill(-1)
    work.size.fill(0)
    work.flags.fill(0)
    return work.parent, work.size, work.flags


def critical_open_count(order: np.ndarray, shape: tuple[int, int], axis: int | str) -> int:
    """Smallest k such that the first k cells of ``order`` (flat C-order indices into an
    array of ``shape``) form an open set that spans along ``axis`` (4-connected, open
    boundaries along ``axis``, periodic across). Returns -1 if even all cells do not span
    (only possible when ``order`` is not a permutation of all cells).
    """
    ax = check_axis(axis)
    nx, ny = _grid(shape)
    if nx * ny >= 2**31:
        raise InputError(f"grid {nx} x {ny} too large for the int32 union-find")
    order = np.ascontiguousarray(order, dtype=np.int64)
    if order.size and (order.min() < 0 or order.max() >= nx * ny):
        raise InputError("order holds indices outside the grid")
    return int(_sweep(order, nx, ny, ax, *_union_find_state(nx * ny)))


#: Cells of :func:`critical_open_count_by_key` after its first block are sorted in chunks of
#: this fraction of all cells ...
_BLOCK_MARGIN = 0.05
#: ... and the block holds the cells opened before the expected critical count minus this
#: fraction, so that the first chunk reaches 0.01 past the expectation. In threshold searches
#: (1024^2, 10 seeds, 96 sweeps) the critical count minus the expected one (the state's own
#: open fraction) had quantiles -0.041 (10 %), -0.016, -0.0006 (median), +0.0009 and +0.0051
#: (90 %): a chunk ending at the expectation missed half of them.
_BLOCK_BELOW = 0.04
#: Keys sampled (on a regular, odd stride through memory) to place the cuts between the block
#: and the chunks. The cuts only decide which cells are sorted together, never the count, so
#: an approximate quantile is enough: the fraction of cells above a cut was off by 0.3 % rms,
#: 0.74 % at most (states of 1024^2 and 2048^2 searches, 3 seeds, fractions 0.3-0.75; a
#: chunk is 5 %). The stride is odd because an even one on a power-of-two grid samples the
#: same few columns of every row: 1.5 % rms, 3.5 % at most. Sorting the sample takes about
#: 0.5 ms, against 9 ms for the two exact partitions of 1024^2 float32 keys it replaced.
_CUT_SAMPLES = 2**14


def _cut_at(sample: np.ndarray, fraction: float) -> float:
    """Key above which about ``fraction`` of the cells lie (``sample``: sorted ascending
    keys); +inf for a fraction <= 0, -inf for >= 1."""
    if fraction <= 0.0:
        return math.inf
    if fraction >= 1.0:
        return -math.inf
    return float(sample[min(int((1.0 - fraction) * sample.size), sample.size - 1)])


def critical_open_count_by_key(key: np.ndarray, axis: int | str, *, expect: float = 0.5,
                               work: SweepWork | None = None) -> int:
    """:func:`critical_open_count` for the order of decreasing ``key`` (cells with a larger
    key open first), without sorting all cells.

    ``expect``: the expected fraction of open cells at the threshold. The cells well before
    it are joined as one block in memory order (only their set matters, not their order),
    and only the cells after it are sorted, a chunk at a time, until the open set spans; a
    block that already spans is shrunk and the sweep redone. The cuts between block and
    chunks come from a sorted sample of the keys; each chunk is collected by a pass over
    the keys in memory order. Same count as
    ``critical_open_count(np.argsort(-key, axis=None), key.shape, axis)`` up to the order of
    equal keys. ``work``: a :func:`sweep_work` of this size, reused instead of
    new arrays (same count).
    """
    ax = check_axis(axis)
    key = np.asarray(key)
    if key.dtype not in (np.float32, np.float64):  # float32 (a search's kept q) as it is
        key = key.astype(np.float64)
    # a nan key compares False everywhere: it opened first in the block and last in a chunk
    # (+-inf keys are ordered and allowed). One summing pass; nan only if a nan (or +inf and
    # -inf together) is there
    with np.errstate(over="ignore", invalid="ignore"):
        total = float(key.sum())
    if math.isnan(total) and np.isnan(key).any():
        idx = tuple(int(i) for i in np.argwhere(np.isnan(key))[0])
        raise InputError(f"key has {int(np.isnan(key).sum())} nan values, first at {idx}")
    nx, ny = (int(v) for v in key.shape)
    n = nx * ny
    if n >= 2**31:
        raise InputError(f"grid {nx} x {ny} too large for the int32 union-find")
    flat = key.ravel()
    if work is None:
        work = sweep_work(n)
    elif work.nxt.size != n:
        raise InputError(f"sweep work for {work.nxt.size} cells passed for {n} keys")
    sample = np.sort(flat[:: max(1, n // _CUT_SAMPLES) | 1])
    start = min(max(float(expect), 0.0), 1.0) - _BLOCK_BELOW
    while True:
        state = _reset(work)
        cut, cut_next = _cut_at(sample, start), _cut_at(sample, start + _BLOCK_MARGIN)
        # the block's pass also collects the first chunk after it (cut_next <= key < cut)
        done, taken = _join_block(flat, cut, cut_next, nx, ny, ax, work.nxt, *state)
        if done >= 0:
            break
        if start <= 0.0:  # spans with no block at all: only cells with key +inf do that
            return critical_open_count(np.argsort(-flat, kind="stable"), key.shape, ax)
        start -= 2 * _BLOCK_MARGIN  # the block already spans: start lower
    fraction = start + _BLOCK_MARGIN
    while True:
        take = work.nxt[:taken]
        order = (_by_decreasing_key(flat, take) if flat.dtype == np.float32
                 else take[np.argsort(-flat[take])])
        k = _sweep(order, nx, ny, ax, *state)
        if k >= 0:
            return done + k
        done += taken
        if cut_next == -math.inf:
            return -1
        fraction += _BLOCK_MARGIN
        cut, cut_next = cut_next, _cut_at(sample, fraction)
        taken = _collect(flat, cut, cut_next, work.nxt)


_RADIX_BITS = 11


@njit(cache=True)
def _by_decreasing_key(key, cells):
    """``cells`` ordered by decreasing float32 ``key[cells]``, ties in their given order: an
    LSD radix sort of the keys' bits mapped to unsigned integers in the opposite order of
    the floats, three passes of 11 bits (-0.0 sorts after +0.0, which only orders a tie).
    A chunk of 5 % of 1024^2 cells takes 0.36 ms against 2.9 ms for ``np.argsort``."""
    n = cells.size
    bits = key.view(np.uint32)
    top = np.uint32(0x80000000)
    ones = np.uint32(0xFFFFFFFF)
    ks = np.empty(n, dtype=np.uint32)
    ks_next = np.empty(n, dtype=np.uint32)
    cs = cells.copy()
    cs_next = np.empty(n, dtype=cells.dtype)
    for i in range(n):
        b = bits[cells[i]]
        # increasing float order as unsigned: flip a negative's bits, set a positive's sign;
        # the complement turns it into decreasing order
        ks[i] = ~(b ^ ones if b & top else b | top)
    mask = np.uint32((1 << _RADIX_BITS) - 1)
    for p in range(3):
        shift = np.uint32(_RADIX_BITS * p)
        start = np.zeros((1 << _RADIX_BITS) + 1, dtype=np.int64)
        for i in range(n):
            start[((ks[i] >> shift) & mask) + 1] += 1
        for j in range(1 << _RADIX_BITS):
            start[j + 1] += start[j]
        for i in range(n):
            d = (ks[i] >> shift) & mask
            at = start[d]
            start[d] = at + 1
            ks_next[at] = ks[i]
            cs_next[at] = cs[i]
        ks, ks_next = ks_next, ks
        cs, cs_next = cs_next, cs
    return cs


@njit(cache=True)
def _collect(key, cut, cut_next, out):
    """Write the indices of the cells with ``cut_next <= key < cut`` into ``out`` in memory
    order; returns how many."""
    taken = 0
    for c in range(key.size):
        v = key[c]
        if v < cut and v >= cut_next:
            out[taken] = c
            taken += 1
    return taken


@njit(cache=True)
def _join_block(key, cut, cut_next, nx, ny, axis, nxt, parent, size, flags):
    """Open every cell with ``key >= cut`` in memory order (fresh union-find state) and
    collect the cells with ``cut_next <= key < cut`` in ``nxt``. Returns (number of cells
    opened, number collected), or (-1, 0) as soon as the block spans along ``axis``.

    Row by row, a run of open cells is one cluster from its first cell on: each later cell
    of the run points straight at the cluster's current root (no find), and the run is
    joined to the row above once per stretch of open cells above it, not once per cell;
    across the periodic seam (ix, 0) - (ix, ny - 1) or (0, iy) - (nx - 1, iy) each bond is
    joined from its later cell. At 1024^2 (a block of 0.37-0.55 of the cells) this takes
    3.4-4.7 ms against 6.3-11 ms for a link per open neighbour.
    ``spanning._spans_4`` runs the same run logic over a mask (written out in both: a shared
    numba helper made the loops 2-3x slower)."""
    nlen = nx if axis == 0 else ny
    opened = 0
    taken = 0
    for ix in range(nx):
        base = ix * ny
        root = -1  # root of the current run's cluster; -1 between runs
        joined_up = False  # the previous cell of the run has an open cell above it
        for iy in range(ny):
            c = base + iy
            v = key[c]
            if v < cut:
                if v >= cut_next:
                    nxt[taken] = c
                    taken += 1
                root = -1
                continue
            opened += 1
            if root < 0:
                _open(c, ix if axis == 0 else iy, nlen, parent, size, flags)
                root = c
                joined_up = False
            else:  # same row, so the same slab flags as the run's first cell, except the end
                parent[c] = root
                size[root] += 1
                if axis == 1 and iy == ny - 1:
                    flags[root] |= _HIGH
            if ix > 0 and parent[c - ny] >= 0:
                if not joined_up:  # the stretch above is one cluster: join it once
                    root = _link(parent, size, flags, c - ny, root)
                    joined_up = True
            else:
                joined_up = False
            if axis == 0 and iy == ny - 1 and parent[base] >= 0:  # periodic in y
                root = _link(parent, size, flags, base, root)
            if axis == 1 and ix == nx - 1 and parent[iy] >= 0:  # periodic in x
                root = _link(parent, size, flags, iy, root)
            if flags[root] == _LOW | _HIGH:
                return -1, 0
    return opened, taken


class BearingBracket(NamedTuple):
    """Bearing-model threshold along one axis: the fluid spans at contact area ``a_lo`` and
    not at ``a_hi``; ``tied`` cells share the critical ``height`` (1 = exact to one cell)."""

    a_lo: float
    a_hi: float
    tied: int
    height: float


def bearing_bracket(heights: np.ndarray, axis: int | str) -> BearingBracket:
    """Exact fluid percolation threshold of the bearing model along ``axis``.

    Contact is the top fraction of heights, so the open set grows from the lowest cell up;
    the first cell whose opening makes the fluid span fixes the threshold. Cells of equal
    height open together, so the bracket widens over their tie group.
    """
    return bearing_brackets(heights, (axis,))[check_axis(axis)]


def bearing_brackets(heights: np.ndarray,
                     axes: tuple[int | str, ...] = (0, 1)) -> dict[int, BearingBracket]:
    """:func:`bearing_bracket` along each of ``axes`` (keyed 0 / 1) from one sort of the
    heights: the sort is most of the work, and only the sweep after it depends on the
    axis."""
    heights = require_field("heights", heights)  # argsort puts nan last: never opened
    flat = heights.ravel()
    n = flat.size
    order = np.argsort(flat, kind="stable")
    hs = flat[order]
    out = {}
    for axis in axes:
        k = critical_open_count(order, heights.shape, axis)
        i0 = int(np.searchsorted(hs, hs[k - 1], side="left"))
        i1 = int(np.searchsorted(hs, hs[k - 1], side="right"))
        out[check_axis(axis)] = BearingBracket(a_lo=1.0 - i1 / n, a_hi=1.0 - i0 / n,
                                               tied=i1 - i0, height=float(hs[k - 1]))
    return out


def _grid(shape) -> tuple[int, int]:
    """(nx, ny) of a 2D grid's ``shape``; InputError for any other."""
    try:
        nx, ny = (int(s) for s in shape)
    except (TypeError, ValueError):
        raise InputError(f"shape must be a 2D grid's (nx, ny), got {shape!r}") from None
    return nx, ny


def _same_grid(gap: np.ndarray, contact: np.ndarray, pressure: np.ndarray) -> None:
    """A contact state's fields on one grid: a transposed mask of the same size passed and
    ordered the cells of another state."""
    shapes = {np.shape(gap), np.shape(contact), np.shape(pressure)}
    if len(shapes) != 1:
        raise InputError(f"gap, contact and pressure must share one grid, got shapes "
                         f"{np.shape(gap)}, {np.shape(contact)}, {np.shape(pressure)}")


def open_first_order(gap: np.ndarray, contact: np.ndarray, pressure: np.ndarray) -> np.ndarray:
    """Flat indices of a contact state from the most open to the most closed cell: open cells
    by decreasing gap, then contact cells by increasing contact pressure."""
    _same_grid(gap, contact, pressure)
    flat_c = np.asarray(contact, dtype=bool).ravel()
    idx_open = np.flatnonzero(~flat_c)
    idx_cont = np.flatnonzero(flat_c)
    o = idx_open[np.argsort(-gap.ravel()[idx_open])]
    c = idx_cont[np.argsort(pressure.ravel()[idx_cont])]
    return np.concatenate([o, c])


def openness(gap: np.ndarray, contact: np.ndarray, pressure: np.ndarray) -> np.ndarray:
    """Key of :func:`open_first_order` (larger opens first): the gap of an open cell, minus
    the contact pressure of a contact cell, shifted by the largest tension (the most negative
    pressure) so that every contact cell ranks below every open cell: on the adhesive hard
    wall a contact cell may lie off the wall, in tension (without the shift the search's
    predictions fell below their own states' areas, and every a_c* came out at the bracket's
    lower end)."""
    _same_grid(gap, contact, pressure)
    closed = np.asarray(contact, dtype=bool)
    # arithmetic instead of np.where: a random mask makes where() 3-10x slower (measured)
    key = np.multiply(gap, ~closed)
    tension = min(float(pressure.min()), 0.0) if pressure.size else 0.0
    key -= np.multiply(pressure - tension if tension < 0 else pressure, closed)
    return key


def predicted_threshold_by_key(key: np.ndarray, axis: int, *, expect: float = 0.5,
                               work: SweepWork | None = None) -> float:
    """:func:`predicted_thresholds` for one axis from the :func:`openness` key (or any key,
    larger opens first), via :func:`critical_open_count_by_key` (``work``: its
    :class:`SweepWork`); ``expect`` is the expected open fraction at the threshold (e.g. the
    state's own open fraction)."""
    return _area_at_count(critical_open_count_by_key(key, axis, expect=expect, work=work),
                          key.size)


def _area_at_count(k: int, n: int) -> float:
    """Contact area at the middle of the k-th opened cell of n (the critical cell)."""
    return 1.0 - (k - 0.5) / n


def predicted_thresholds(order: np.ndarray, shape: tuple[int, int],
                         axes: Iterable[int | str] = (0, 1)) -> dict[int, float]:
    """Predicted a_c* per axis: the contact area at which the open set built in ``order``
    first spans, taken at the middle of the critical cell (exact for the bearing model with
    heights as the order, first order for an elastic state with :func:`open_first_order`)."""
    nx, ny = _grid(shape)
    if np.size(order) != nx * ny:  # the areas are fractions of the grid's cells
        raise InputError(f"order must hold each of the {nx} x {ny} cells once, got "
                         f"{np.size(order)} indices")
    # keyed by axis number whether an axis was given as 0/1 or "x"/"y"
    return {check_axis(ax): _area_at_count(critical_open_count(order, shape, ax), nx * ny)
            for ax in axes}
