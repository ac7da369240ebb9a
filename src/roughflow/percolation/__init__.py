"""Percolation of fluid channels and contact patches (paper Sect. 2.2 and 3.2).

- :func:`label`: periodic cluster labelling (4- or 8-connected).
- :func:`percolates`, :func:`spanning_cells`: does the fluid span along an axis, and which
  cells carry flow; :func:`contact_percolates`: the dual statement for contact (8-connected).
- :func:`threshold`: critical contact area a_c* per direction (elastic/adhesive: bisection
  in pressure with warm-started contact solves; bearing: exact union-find sweep).
- :mod:`.clusters`: cluster-size statistics and the percolating-channel map (Fig. 1 b, c).
"""

from .clusters import (
    ClusterStats,
    cluster_sizes,
    cluster_stats,
    fisher_exponent,
    percolation_map,
    size_distribution,
)
from .critical import Threshold, ThresholdNotBracketed, threshold
from .labels import label
from .spanning import contact_percolates, percolates, spanning_cells
from .sweep import critical_open_count

__all__ = [
    "ClusterStats",
    "Threshold",
    "ThresholdNotBracketed",
    "cluster_sizes",
    "cluster_stats",
    "fisher_exponent",
    "contact_percolates",
    "critical_open_count",
    "label",
    "percolates",
    "percolation_map",
    "size_distribution",
    "spanning_cells",
    "threshold",
]
