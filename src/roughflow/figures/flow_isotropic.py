"""Fig. 5: conductance versus contact area, isotropic, three contact models."""

from __future__ import annotations

import numpy as np
import xarray as xr
from matplotlib.figure import Figure

from roughflow.datasets.sweep import area_values
from roughflow.defaults import MODELS, STUDY_FIXED
from roughflow.errors import InputError

from ._flow import curve, ladder, mark_edge, points, sealed, sigma_ref
from .captions import CAPTIONS

CAPTION = CAPTIONS["flow_isotropic"]
TITLES = {"elastic": "elastic, non-adhesive", "adhesive": "short-range adhesion",
          "bearing": "bearing-area model"}


def draw(ds: xr.Dataset, fit: xr.Dataset | None = None) -> Figure:
    fixed, other = STUDY_FIXED["flow_isotropic"]
    for key, value in fixed.items():
        values = [float(v) for v in np.atleast_1d(ds[key].values)] if key in ds else []
        if any(not np.isclose(v, value) for v in values):
            raise InputError(f"the isotropic flow figure needs {key} = {value:g}, the dataset "
                             f"has {key} {', '.join(f'{v:g}' for v in values)} ({other} "
                             "draws it)")
    models = [m for m in MODELS if m in ds["model"].values]
    fig = Figure(figsize=(4.6 * len(models), 4.2), layout="constrained")
    axes = fig.subplots(1, len(models), squeeze=False)
    for ax, model, tag in zip(axes[0], models, "abc", strict=False):
        sub = ladder(ds, model)
        ref = sigma_ref(sub)
        a = area_values(sub)
        rey = sub["sigma"].mean("axis")
        x, y = points(a, rey / ref)
        ax.plot(x, y, "o", mfc="white", color="k", label="full Reynolds")
        mark_edge(ax, sealed(a, rey), color="k", label="sealed (sigma = 0)")
        emt = sub["sigma_emt"]
        x, y = curve(a, emt.sel(emt="isotropic").isel(axis=0) / ref)
        ax.plot(x, y, "-", color="tab:blue", label="full Bruggeman")
        x, y = curve(a, sub["sigma_closed_form"] / ref)
        ax.plot(x, y, "--", color="tab:green", label="closed form, Eq. 16")
        # one value per model (config a_c_star_alt); NaN where a size of the study did not
        # run; a study aggregated by an older roughflow has it as an attribute
        alts = (sub["a_c_star_alt"].values if "a_c_star_alt" in sub
                else np.array([ds.attrs.get("a_c_star_alt", np.nan)], dtype=float))
        alt = float(alts[np.isfinite(alts)][0]) if np.isfinite(alts).any() else np.nan
        if model == "elastic" and np.isfinite(alt):
            x, y = curve(a, emt.sel(emt="isotropic_alt").isel(axis=0) / ref)
            ax.plot(x, y, ":", color="tab:purple", label=f"full Bruggeman, a_c* = {alt:g}")
        if not (np.nanmax(a.values, initial=0.0) > 0):
            ax.text(0.5, 0.5, "no contact area in the data:\nsee the job log", ha="center",
                    va="center", transform=ax.transAxes, color="tab:red")
        ax.set_yscale("log")
        ax.set_xlim(0, max(0.5, float(np.nanmax(a.values)) + 0.05))
        ax.set_xlabel("relative contact area a_c")
        ax.set_ylabel("sigma / sigma_ref")
        ax.set_title(f"({tag}) {TITLES[model]}", fontsize=10)
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=7)
    return fig
