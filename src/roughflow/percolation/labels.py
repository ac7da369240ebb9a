"""Cluster labelling with periodic seams (paper Sect. 2.2, Hoshen-Kopelman equivalent).

``scipy.ndimage.label`` labels the clusters of the open (non-periodic) grid; labels that
touch across a periodic seam are then merged with a connected-components pass on the
small graph of seam pairs. Arrays are indexed ``[ix, iy]`` (axis 0 is x, axis 1 is y).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from roughflow.errors import InputError, check_axis, require_mask  # noqa: F401 (re-exported)

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

_STRUCTURES = {
    4: ndimage.generate_binary_structure(2, 1),
    8: ndimage.generate_binary_structure(2, 2),
}


def check_connectivity(connectivity: int) -> int:
    if isinstance(connectivity, (bool, np.bool_)) or connectivity not in (4, 8):
        raise InputError(f"connectivity must be 4 or 8, got {connectivity!r}")
    return int(connectivity)


def _check_periodic(periodic) -> tuple[bool, bool]:
    try:
        px, py = periodic
    except (TypeError, ValueError):
        raise InputError(f"periodic must be a pair of booleans, got {periodic!r}") from None
    return bool(px), bool(py)


def _seam_pairs(lab: np.ndarray, periodic: tuple[bool, bool], connectivity: int) -> np.ndarray:
    """Label pairs (k, 2) that touch across the periodic seams (both labels > 0)."""
    pairs = []
    for axis in (0, 1):
        if not periodic[axis]:
            continue
        first = lab.take(0, axis=axis)
        last = lab.take(-1, axis=axis)
        pairs.append((first, last))
        if connectivity == 8:
            if periodic[1 - axis]:
                pairs.append((first, np.roll(last, 1)))
                pairs.append((first, np.roll(last, -1)))
            else:
                pairs.append((first[1:], last[:-1]))
                pairs.append((first[:-1], last[1:]))
    if not pairs:
        return np.empty((0, 2), dtype=lab.dtype)
    a = np.concatenate([p[0] for p in pairs])
    b = np.concatenate([p[1] for p in pairs])
    keep = (a > 0) & (b > 0) & (a != b)
    return np.stack([a[keep], b[keep]], axis=1)


def label_raw(
    mask: np.ndarray, periodic: tuple[bool, bool], connectivity: int
) -> tuple[np.ndarray, np.ndarray, int]:
    """Non-periodic labels, a lookup table raw label -> merged label, and the cluster count.

    ``lut[raw]`` gives the final label (0 for the background); internal helper that lets
    callers relabel only the cells they need.
    """
    raw, n = ndimage.label(mask, structure=_STRUCTURES[connectivity])
    lut, n = merge_seams(raw, n, periodic, connectivity)
    return raw, lut, n


def merge_seams(raw: np.ndarray, n: int, periodic: tuple[bool, bool],
                connectivity: int) -> tuple[np.ndarray, int]:
    """Lookup table raw label -> merged label and the cluster count, for the non-periodic
    labels ``raw`` (``n`` clusters, from ``ndimage.label``) joined across the seams marked
    in ``periodic``. One labelling serves several seam choices (e.g. both flow axes)."""
    lut = np.arange(n + 1, dtype=raw.dtype)
    if n == 0:
        return lut, 0
    pairs = _seam_pairs(raw, periodic, connectivity)
    if pairs.shape[0] == 0:
        return lut, n
    graph = coo_matrix(
        (np.ones(pairs.shape[0], dtype=np.int8), (pairs[:, 0], pairs[:, 1])), shape=(n + 1, n + 1)
    )
    ncomp, comp = connected_components(graph, directed=False)
    # Components are numbered in order of their lowest node: node 0 (background, no edges)
    # gets 0, the clusters 1..ncomp-1, so the lookup table is the component index itself.
    return comp.astype(raw.dtype), ncomp - 1


def label(
    mask: ArrayLike, *, periodic: tuple[bool, bool] = (True, True), connectivity: int = 4
) -> tuple[np.ndarray, int]:
    """Label the connected clusters of the True cells of a 2D boolean ``mask``.

    ``periodic=(px, py)`` merges clusters across the seam along x (axis 0) and/or y
    (axis 1); ``connectivity`` is 4 (shared faces) or 8 (faces and corners; diagonal
    neighbours across a seam included). Returns ``(labels, n)``: int32 labels 1..n on the
    True cells, 0 elsewhere.
    """
    m = require_mask("mask", mask)
    conn = check_connectivity(connectivity)
    per = _check_periodic(periodic)
    raw, lut, n = label_raw(m, per, conn)
    if n == lut.size - 1:  # no seam merged two clusters: the raw labels are final
        return raw, n
    return lut[raw], n
