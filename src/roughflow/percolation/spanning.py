"""Does the fluid (or the contact) span the cell along an axis? (paper Sect. 2.2)

Fluid = open (non-contact) cells, connected through shared faces (4 neighbours). For flow
along ``axis`` the boundaries along ``axis`` are open (reservoirs) and the cell is periodic
across it; a cluster percolates when it touches both the first and the last slab along
``axis``. Contact cells connect through 8 neighbours, which makes the two phases exactly
dual on the square grid: fluid spans x  <=>  no contact cluster winds around y on the same
cylinder (open in x, periodic in y), and vice versa (docs/physics.md Sect. 4).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from scipy import ndimage

from roughflow._jit import njit
from roughflow.errors import InputError, require_mask

from .labels import _STRUCTURES, check_axis, check_connectivity, merge_seams
from .sweep import SweepWork, _find, _link, sweep_work

if TYPE_CHECKING:
    from collections.abc import Iterable

    from numpy.typing import ArrayLike


def _periodic_across(axis: int, periodic: bool = True) -> tuple[bool, bool]:
    """Seams of a cell open along ``axis``: periodic across it, or walls (``periodic``
    False, a non-periodic scan)."""
    return (False, periodic) if axis == 0 else (periodic, False)


def _spanning_labels(open_mask: np.ndarray, axis: int, connectivity: int,
                     periodic: bool = True, raw: tuple[np.ndarray, int] | None = None):
    """(raw labels, lookup table, merged labels touching both ends along ``axis``);
    ``raw``: the non-periodic labelling of ``open_mask`` if already done."""
    if raw is None:
        raw = ndimage.label(open_mask, structure=_STRUCTURES[connectivity])
    raw, n = raw
    lut, _ = merge_seams(raw, n, _periodic_across(axis, periodic), connectivity)
    first = lut[raw.take(0, axis=axis)]
    last = lut[raw.take(-1, axis=axis)]
    common = np.intersect1d(first[first > 0], last[last > 0])
    return raw, lut, common


def percolates(open_mask: ArrayLike, axis: int | str, *, connectivity: int = 4,
               periodic: bool = True) -> bool:
    """True when a cluster of open (True) cells connects the two ends along ``axis``.

    ``axis`` 0 = x, 1 = y; open boundaries along ``axis``, periodic across it (closed
    walls across it with ``periodic=False``, for non-periodic scans);
    ``connectivity`` 4 (fluid, default) or 8.
    """
    m = require_mask("open_mask", open_mask)
    ax = check_axis(axis)
    conn = check_connectivity(connectivity)
    if not (m.take(0, axis=ax).any() and m.take(-1, axis=ax).any()):
        return False
    return _spanning_labels(m, ax, conn, bool(periodic))[2].size > 0


# bits of a cluster's slabs in _spans_4: first / last along x, first / last along y
_X_ENDS, _Y_ENDS = 3, 12


@njit(cache=True)
def _seam_spans(pairs_a, pairs_b, ends, parent, aux, aux_flags, flags):
    """Whether the clusters of a seamless union-find (``parent``, slab bits ``flags``) span
    between the two slabs ``ends`` once the cells ``pairs_a[i]`` and ``pairs_b[i]`` (open,
    across a periodic seam) are joined: a second union-find over the roots alone (``aux``,
    ``aux_flags``: scratch arrays indexed by root), leaving the first one as it is."""
    m = pairs_a.size
    for i in range(m):  # every root a pair touches, before any join
        for c in (pairs_a[i], pairs_b[i]):
            r = _find(parent, c)
            aux[r] = r
            aux_flags[r] = flags[r] & ends
    for i in range(m):
        a = _find(aux, _find(parent, pairs_a[i]))
        b = _find(aux, _find(parent, pairs_b[i]))
        if a != b:
            aux[b] = a
            aux_flags[a] |= aux_flags[b]
            if aux_flags[a] == ends:
                return True
    return False


@njit(cache=True)
def _spans_4(open_, nx, ny, periodic, parent, size, flags, aux_flags):
    """(spans along x, spans along y) of the 4-connected open cells of ``open_`` (flat, C
    order): one raster pass of a union-find without seams, a row's run of open cells one
    cluster from its first cell on and joined to the row above once per stretch of open
    cells there (as ``sweep._join_block``), each root keeping which of the four slabs its
    cluster touches; then, when ``periodic``, each axis's own seam joined over the roots
    alone (:func:`_seam_spans`). Arrays of ``nx ny`` cells; none needs resetting.

    The run logic is written out here and in ``sweep._join_block`` rather than shared: as a
    numba helper (inline="always" or not) returning (root, joined_up) it made both loops
    2-3x slower at 1024^2 (measured), so the two copies must change together."""
    spans_x = False
    spans_y = False
    for ix in range(nx):
        base = ix * ny
        root = -1
        joined_up = False
        for iy in range(ny):
            c = base + iy
            if not open_[c]:
                root = -1
                continue
            if root < 0:
                f = 0
                if ix == 0:
                    f |= 1
                if ix == nx - 1:
                    f |= 2
                if iy == 0:
                    f |= 4
                if iy == ny - 1:
                    f |= 8
                parent[c] = c
                size[c] = 1
                flags[c] = f
                root = c
                joined_up = False
            else:
                parent[c] = root
                size[root] += 1
                if iy == ny - 1:
                    flags[root] |= 8
            if ix > 0 and open_[c - ny]:
                if not joined_up:
                    root = _link(parent, size, flags, c - ny, root)
                    joined_up = True
            else:
                joined_up = False
            f = flags[root]
            spans_x |= (f & _X_ENDS) == _X_ENDS
            spans_y |= (f & _Y_ENDS) == _Y_ENDS
        if spans_x and spans_y:
            return True, True
    if periodic:
        aux = size  # the sizes are not needed any more
        if not spans_x:  # flow along x: periodic in y, seam (ix, 0) - (ix, ny - 1)
            first = np.arange(nx) * ny
            last = first + (ny - 1)
            both = np.flatnonzero(open_[first] & open_[last])
            spans_x = _seam_spans(first[both], last[both], _X_ENDS, parent, aux, aux_flags,
                                  flags)
        if not spans_y:  # flow along y: periodic in x, seam (0, iy) - (nx - 1, iy)
            first = np.arange(ny)
            last = first + (nx - 1) * ny
            both = np.flatnonzero(open_[first] & open_[last])
            spans_y = _seam_spans(first[both], last[both], _Y_ENDS, parent, aux, aux_flags,
                                  flags)
    return spans_x, spans_y


def percolates_along(open_mask: ArrayLike, axes: Iterable[int | str] = (0, 1), *,
                     connectivity: int = 4, periodic: bool = True,
                     work: SweepWork | None = None) -> dict[int, bool]:
    """:func:`percolates` along each of ``axes`` at once (the axes differ only in which seam
    is periodic); ``{axis: spans}``. 4-connected: one union-find pass (:func:`_spans_4`;
    ``work``: a :func:`~roughflow.percolation.sweep_work` of the grid's size, reused instead
    of new arrays); 8-connected: one labelling."""
    m = require_mask("open_mask", open_mask)
    axes = tuple(check_axis(ax) for ax in axes)
    conn = check_connectivity(connectivity)
    if conn == 4:
        if work is None:
            work = sweep_work(m.size)
        elif work.parent.size != m.size:
            raise InputError(f"sweep work for {work.parent.size} cells passed for a mask of "
                             f"{m.size}")
        spans = _spans_4(np.ascontiguousarray(m).reshape(-1), m.shape[0], m.shape[1],
                         bool(periodic), work.parent, work.size, work.flags, work.nxt)
        return {ax: bool(spans[ax]) for ax in axes}
    raw = None
    out = {}
    for ax in axes:
        if not (m.take(0, axis=ax).any() and m.take(-1, axis=ax).any()):
            out[ax] = False
            continue
        if raw is None:
            raw = ndimage.label(m, structure=_STRUCTURES[conn])
        out[ax] = _spanning_labels(m, ax, conn, bool(periodic), raw)[2].size > 0
    return out


def spanning_cells(open_mask: ArrayLike, axis: int | str, *, connectivity: int = 4,
                   periodic: bool = True) -> np.ndarray:
    """Bool mask of the open cells in clusters that touch both ends along ``axis``.

    These are the cells that can carry flow along ``axis`` (the rest are dead ends or
    isolated pools; within a spanning cluster, dead-end branches are included).
    """
    m = require_mask("open_mask", open_mask)
    ax = check_axis(axis)
    conn = check_connectivity(connectivity)
    raw, lut, common = _spanning_labels(m, ax, conn, bool(periodic))
    if common.size == 0:
        return np.zeros(m.shape, dtype=bool)
    good_raw = np.isin(lut, common)
    good_raw[0] = False
    return good_raw[raw]


def _wraps(mask: np.ndarray, axis: int, connectivity: int) -> bool:
    """True when a cluster winds around the periodic direction ``axis`` (open across it).

    Labels the grid without periodicity, then joins labels across the seam of ``axis``
    with a union-find that keeps the winding number (offset) of each label: a seam pair
    whose two labels are already joined with a different offset closes a loop around
    the cylinder.
    """
    raw, n = ndimage.label(mask, structure=_STRUCTURES[connectivity])
    if n == 0:
        return False
    hi = raw.take(-1, axis=axis)  # last slab; its neighbour across the seam is slab 0
    lo = raw.take(0, axis=axis)
    pairs = [(hi, lo)]
    if connectivity == 8:
        pairs += [(hi[1:], lo[:-1]), (hi[:-1], lo[1:])]
    a = np.concatenate([p[0] for p in pairs])
    b = np.concatenate([p[1] for p in pairs])
    keep = (a > 0) & (b > 0)
    if not keep.any():
        return False
    edges = np.unique(np.stack([a[keep], b[keep]], axis=1), axis=0)
    parent: dict[int, int] = {}
    offset: dict[int, int] = {}  # winding of node relative to its parent

    def find(x: int) -> tuple[int, int]:
        w = 0
        path = []
        while parent.get(x, x) != x:
            path.append(x)
            w += offset[x]
            x = parent[x]
        # path compression: point every visited node at the root with its total offset
        acc = w
        for node in path:
            o = offset[node]
            parent[node] = x
            offset[node] = acc
            acc -= o
        return x, w

    for u, v in edges.tolist():  # crossing from u (last slab) to v (slab 0): winding +1
        ru, wu = find(u)
        rv, wv = find(v)
        if ru == rv:
            if wv - wu != 1:
                return True
        else:
            parent[rv] = ru
            offset[rv] = wu + 1 - wv
    return False


def contact_percolates(contact_mask: ArrayLike, axis: int | str) -> bool:
    """True when an 8-connected contact cluster spans the cell along ``axis``, closing on
    itself through the periodic seam of ``axis`` (a contact wall around the cylinder that
    is open across ``axis``).

    This is the geometry that blocks flow across ``axis``: for any mask,
    ``contact_percolates(c, 1) == (not percolates(~c, 0))`` and likewise with the axes
    swapped (4/8 duality on the square grid).
    """
    m = require_mask("contact_mask", contact_mask)
    ax = check_axis(axis)
    return _wraps(m, ax, 8)
