"""Fig. 5: conductance versus contact area, isotropic, three contact models."""

from __future__ import annotations

import numpy as np
import xarray as xr
from matplotlib.figure import Figure

from roughflow.datasets.sweep import area_values
from roughflow.defaults import MODELS, STUDY_FIXED
from roughflow.errors import InputError

from ._flow import curve, grid, mark_edge, not_run, points, rows, sealed, sigma_ref, tag
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
    table = rows(ds, models)
    fig = Figure(figsize=(4.6 * len(models), 4.2 * len(table)), layout="constrained")
    right = {m: max(0.5, _largest([area_values(r.ladders[m]) for r in table
                                   if m in r.ladders]) + 0.05) for m in models}
    for i, (row, axes) in enumerate(zip(table, grid(fig, table, len(models)), strict=True)):
        for j, (ax, model) in enumerate(zip(axes, models, strict=True)):
            if model not in row.ladders:
                not_run(ax, model)
                continue
            _panel(ax, row.ladders[model], model, ds)
            ax.set_xlim(0, right[model])
            ax.set_title(f"{tag(j, i, len(table))} {TITLES[model]}", fontsize=10)
    return fig


def _largest(areas: list[xr.DataArray]) -> float:
    """The largest contact area of a column's panels (NaN where none has one): the x range
    they share."""
    tops = [float(np.nanmax(a.values)) for a in areas]
    return max((t for t in tops if np.isfinite(t)), default=np.nan)


def _panel(ax, sub: xr.Dataset, model: str, ds: xr.Dataset) -> None:
    """One model's ladder at one setting: Reynolds points and the theory lines."""
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
    ax.set_xlabel("relative contact area a_c")
    ax.set_ylabel("sigma / sigma_ref")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=7)
