"""Percolation of fluid channels and contact patches on a grid (paper Sect. 2.2 and 3.2).

Pure topology on boolean and float arrays; no contact solves (the threshold search that
drives them is :mod:`roughflow.search`).

- :func:`label`: periodic cluster labelling (4- or 8-connected).
- :func:`percolates`, :func:`spanning_cells`: does the fluid span along an axis, and which
  cells carry flow (:func:`percolates_along`: several axes from one pass);
  :func:`contact_percolates`: the dual statement for contact (8-connected).
- :func:`critical_open_count`, :func:`bearing_bracket`, :func:`predicted_thresholds`:
  exact spanning thresholds of a growing open set (one union-find pass);
  :func:`critical_open_count_by_key`, :func:`predicted_threshold_by_key`: the same from a
  key per cell, sorting only the cells near the threshold.
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
from .labels import check_axis, label
from .spanning import contact_percolates, percolates, percolates_along, spanning_cells
from .sweep import (
    BearingBracket,
    SweepWork,
    bearing_bracket,
    bearing_brackets,
    critical_open_count,
    critical_open_count_by_key,
    open_first_order,
    openness,
    predicted_threshold_by_key,
    predicted_thresholds,
    sweep_work,
)

__all__ = [
    "BearingBracket",
    "ClusterStats",
    "SweepWork",
    "bearing_bracket",
    "bearing_brackets",
    "check_axis",
    "cluster_sizes",
    "cluster_stats",
    "contact_percolates",
    "critical_open_count",
    "critical_open_count_by_key",
    "fisher_exponent",
    "label",
    "open_first_order",
    "openness",
    "percolates",
    "percolates_along",
    "percolation_map",
    "predicted_threshold_by_key",
    "predicted_thresholds",
    "size_distribution",
    "spanning_cells",
    "sweep_work",
]
