"""Fig. 4: a_c* versus gamma for two Hurst exponents."""

from __future__ import annotations

import numpy as np
import xarray as xr
from matplotlib.figure import Figure

from roughflow.datasets.sweep import single_setting, threshold_values
from roughflow.defaults import STUDY_ONE_VALUE

from ._style import setting_text
from ._threshold import (
    format_gamma_axis,
    no_data,
    note_unbracketed,
    one_size,
    plot_vs_gamma,
)
from .captions import CAPTIONS

CAPTION = CAPTIONS["threshold_vs_hurst"]


def draw(ds: xr.Dataset, fit: xr.Dataset | None = None) -> Figure:
    fig = Figure(figsize=(5.5, 4.2), layout="constrained")
    ax = fig.subplots()
    a = single_setting(threshold_values(ds), STUDY_ONE_VALUE["threshold_vs_hurst"])
    a = one_size(a)
    hursts = sorted(a["hurst"].values)
    if not np.isfinite(a.values).any():
        no_data(ax)
    for h in hursts:
        sub = a.sel(hurst=h)
        if not np.isfinite(sub.values).any():
            continue
        low = h == hursts[0] and len(hursts) > 1
        plot_vs_gamma(ax, sub, marker="^" if low else "o", filled=low, label=f"H = {h:g}",
                      offset=1.02 if low else 1.0)
    format_gamma_axis(ax, a["gamma"].values, str(a["model"].values))
    ax.set_title(setting_text(a), fontsize=9)
    ax.legend(fontsize=7)
    note_unbracketed(fig, ds)
    return fig
