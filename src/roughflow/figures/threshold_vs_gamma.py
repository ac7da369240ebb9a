"""Fig. 2: a_c* along x and y versus gamma; elastic (two eps_f) and bearing model."""

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

CAPTION = CAPTIONS["threshold_vs_gamma"]
MARKERS = ("o", "s", "^", "D")


def draw(ds: xr.Dataset, fit: xr.Dataset | None = None) -> Figure:
    models = [m for m in ("elastic", "bearing", "adhesive") if m in ds["model"].values]
    fig = Figure(figsize=(5.2 * len(models), 4.2), layout="constrained")
    axes = fig.subplots(1, len(models), squeeze=False)
    # one H, and one size per gamma (each gamma may have its own, e.g. the paper's)
    a_all = one_size(single_setting(threshold_values(ds), STUDY_ONE_VALUE["threshold_vs_gamma"]))
    for ax, model, tag in zip(axes[0], models, "abc", strict=False):
        am = a_all.sel(model=model)
        eps_list = [e for e in sorted(am["eps_f"].values, reverse=True)
                    if np.isfinite(am.sel(eps_f=e).values).any()]
        for i, e in enumerate(eps_list):
            plot_vs_gamma(ax, am.sel(eps_f=e), marker=MARKERS[i % len(MARKERS)],
                          filled=i == 0, label=f"eps_f = 1/{1 / e:.3g}",
                          offset=1.0 + 0.02 * i)
        if not eps_list:
            no_data(ax)
        format_gamma_axis(ax, ds["gamma"].values, model)
        ax.set_title(f"({tag}) {setting_text(am)}", fontsize=10)  # eps_f: in the legend
        ax.legend(fontsize=7)
    note_unbracketed(fig, ds)
    return fig
