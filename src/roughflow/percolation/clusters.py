"""Cluster statistics of a contact state and the percolating-channel map (paper Fig. 1 b, c).

Contact patches and fluid clusters are labelled periodically in both directions (the cell
is a periodic repeat); sizes are counted in grid cells (multiply by dx dy for areas in
L^2). The contact-patch-size distribution n(s) ~ s^(-tau) has a Fisher exponent of about
2 - H/2 for repulsive elastic contacts (paper Sect. 3.2, Mueser & Wang 2018).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from roughflow._repr import summary_repr
from roughflow.errors import InputError, require_mask

from .labels import label
from .spanning import spanning_cells

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

#: Values of :func:`percolation_map`.
CONTACT, FLUID, PERCOLATING = 0, 1, 2
#: Their names, by value, as CF ``flag_meanings`` words.
PHASE_NAMES = {CONTACT: "contact", FLUID: "non_percolating_fluid",
               PERCOLATING: "percolating_fluid"}


def cluster_sizes(mask: ArrayLike, *, periodic: tuple[bool, bool] = (True, True),
                  connectivity: int = 4) -> np.ndarray:
    """Sizes (number of cells) of the clusters of True cells, largest first."""
    lab, n = label(mask, periodic=periodic, connectivity=connectivity)
    sizes = np.bincount(lab.ravel(), minlength=n + 1)[1:]
    return np.sort(sizes)[::-1]


def size_distribution(sizes: ArrayLike, *,
                      bins_per_decade: int = 5) -> tuple[np.ndarray, np.ndarray]:
    """Logarithmically binned cluster-number density n(s).

    Returns ``(s, n)``: geometric bin centres and the number of clusters per unit size in
    each bin (count / bin width), so that n(s) ~ s^(-tau) is a straight line of slope
    -tau in a log-log plot. Empty bins are dropped.
    """
    s = np.asarray(sizes)
    if s.ndim != 1 or s.size == 0 or (s < 1).any():
        raise InputError(f"sizes must be a non-empty 1D array of positive counts, got {s!r}")
    if isinstance(bins_per_decade, bool) or int(bins_per_decade) < 1:
        raise InputError(f"bins_per_decade must be a positive integer, got {bins_per_decade!r}")
    top = np.log10(s.max()) + 1e-9
    nb = max(1, int(np.ceil(top * bins_per_decade)))
    edges = np.unique(np.floor(np.logspace(0, top, nb + 1)).astype(np.int64))
    edges[-1] = s.max() + 1
    if edges.size < 2:
        edges = np.array([1, s.max() + 1])
    counts, _ = np.histogram(s, bins=edges)
    width = np.diff(edges).astype(float)
    centre = np.sqrt(edges[:-1] * (edges[1:] - 1.0).clip(min=1.0))
    keep = counts > 0
    return centre[keep], counts[keep] / width[keep]


def fisher_exponent(sizes: ArrayLike, *, s_min: float = 4.0, s_max: float | None = None,
                    bins_per_decade: int = 5) -> float:
    """Least-squares slope -tau of log n(s) versus log s over ``s_min <= s <= s_max``."""
    s, n = size_distribution(sizes, bins_per_decade=bins_per_decade)
    sel = s >= s_min
    if s_max is not None:
        sel &= s <= s_max
    if sel.sum() < 3:
        raise InputError(
            f"fewer than 3 occupied size bins in [{s_min}, {s_max}]: cannot fit tau"
        )
    slope = np.polyfit(np.log(s[sel]), np.log(n[sel]), 1)[0]
    return float(-slope)


@dataclass(frozen=True)
class ClusterStats:
    """Cluster statistics of one contact mask (sizes in grid cells, largest first)."""

    __repr__ = summary_repr

    area_fraction: float
    n_patches: int
    n_fluid_clusters: int
    patch_sizes: np.ndarray
    fluid_sizes: np.ndarray
    percolating_fraction_x: float  # fraction of all cells in x-spanning fluid clusters
    percolating_fraction_y: float


def cluster_stats(contact_mask: ArrayLike, *, patch_connectivity: int = 4) -> ClusterStats:
    """Patches (contact, ``patch_connectivity``-connected, default 4 as in the paper) and
    fluid clusters (4-connected), both periodic, and the share of spanning fluid."""
    c = require_mask("contact_mask", contact_mask)
    patches = cluster_sizes(c, connectivity=patch_connectivity)
    fluid = cluster_sizes(~c, connectivity=4)
    return ClusterStats(
        area_fraction=float(c.mean()),
        n_patches=int(patches.size),
        n_fluid_clusters=int(fluid.size),
        patch_sizes=patches,
        fluid_sizes=fluid,
        percolating_fraction_x=float(spanning_cells(~c, 0).mean()),
        percolating_fraction_y=float(spanning_cells(~c, 1).mean()),
    )


def percolation_map(contact_mask: ArrayLike, axis: int | str = 0) -> np.ndarray:
    """int8 map: 0 contact, 1 non-percolating fluid, 2 fluid spanning along ``axis``
    (paper Fig. 1 b, c: dark blue = 2, light blue = 1, orange = 0)."""
    c = require_mask("contact_mask", contact_mask)
    out = np.full(c.shape, FLUID, dtype=np.int8)
    out[c] = CONTACT
    out[spanning_cells(~c, axis)] = PERCOLATING
    return out
