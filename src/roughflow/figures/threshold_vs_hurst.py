"""Fig. 4: a_c* versus gamma for two Hurst exponents."""

from __future__ import annotations

import numpy as np
import xarray as xr
from matplotlib.figure import Figure

from roughflow.datasets.sweep import single_setting, threshold_values
from roughflow.defaults import STUDY_ONE_VALUE

from ._threshold import format_gamma_axis, one_size, plot_vs_gamma

CAPTION = (
    "a_c* is perimeter-corrected (first-order grid bias of the contact area removed, "
    "docs/accuracy.md) on grids with >= 4 points per lambda_s, raw on coarser ones (raw "
    "values there are biased high by about 0.03). "
    "Critical contact areas a_c* along x (stretching, blue) and y (contraction, red) versus "
    "the Peklenik number gamma for the Hurst exponents of the config (paper Fig. 4: "
    "H = 0.3 full triangles, H = 0.8 open circles), elastic contact, eps_f = 1/16, "
    "L/lambda_r = 4 max(sqrt(gamma), 1/sqrt(gamma)); seed means with standard errors."
)


def draw(ds: xr.Dataset, fit=None) -> Figure:
    fig = Figure(figsize=(5.5, 4.2), layout="constrained")
    ax = fig.subplots()
    a = single_setting(threshold_values(ds), STUDY_ONE_VALUE["threshold_vs_hurst"])
    a = one_size(a)
    hursts = sorted(a["hurst"].values)
    for h in hursts:
        sub = a.sel(hurst=h)
        if not np.isfinite(sub.values).any():
            continue
        low = h == hursts[0] and len(hursts) > 1
        plot_vs_gamma(ax, sub, marker="^" if low else "o", filled=low, label=f"H = {h:g}",
                      offset=1.02 if low else 1.0)
    format_gamma_axis(ax, a["gamma"].values)
    ax.legend(fontsize=7)
    return fig
