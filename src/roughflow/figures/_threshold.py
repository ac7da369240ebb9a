"""a_c* versus gamma, shared by Fig. 2 and Fig. 4."""

from __future__ import annotations

import numpy as np
import xarray as xr

from roughflow.defaults import A_C_STAR_PAPER
from roughflow.errors import InputError

from ._style import AXIS_COLOR, seed_stats


def one_size(a: xr.DataArray) -> xr.DataArray:
    """``a`` without its ``eps_t`` dimension, where each point (gamma, H, ...) has data at
    one system size (each gamma may have its own); InputError where one has several: a
    maximum over eps_t would mix the sizes seed by seed, giving a point that matches
    neither size."""
    if "eps_t" not in a.dims:
        return a
    has = a.notnull().any([d for d in ("seed", "axis") if d in a.dims])
    several = has.sum("eps_t") > 1
    if bool(several.any()):
        where = several.where(several, drop=True)
        point = ", ".join(f"{d}={where[d].values[0]}" for d in where.dims)
        sizes = has.sel({d: where[d].values[0] for d in where.dims})
        found = ", ".join(f"{e:g}" for e in a["eps_t"].values[sizes.values])
        raise InputError(f"this figure shows one system size per point; {point} has data at "
                         f"eps_t {found} (threshold_vs_size draws the sizes)")
    return a.max("eps_t", skipna=True)


def plot_vs_gamma(ax, a: xr.DataArray, *, marker: str = "o", filled: bool = True,
                  label: str = "", offset: float = 1.0) -> None:
    """a_c*(gamma) along x (blue) and y (red): seed mean +- standard error.

    ``a`` has dims (gamma, seed, axis); gammas without data are skipped.
    """
    mean, sem, n = seed_stats(a)
    for axis in ("x", "y"):
        m = mean.sel(axis=axis)
        ok = np.isfinite(m.values)
        if not ok.any():
            continue
        g = a["gamma"].values[ok] * (offset if axis == "x" else 1 / offset)
        color = AXIS_COLOR[axis]
        ax.errorbar(g, m.values[ok], yerr=sem.sel(axis=axis).values[ok], marker=marker,
                    ls="-", lw=0.8, color=color, mfc=color if filled else "white", ms=6,
                    capsize=2, label=f"{label} {axis} ({'easy' if axis == 'x' else 'hard'})")


def format_gamma_axis(ax, gammas) -> None:
    ax.set_xscale("log")
    ax.set_xticks(list(gammas))
    ax.set_xticklabels([f"{g:g}" for g in gammas])
    ax.minorticks_off()
    ax.set_xlabel("Peklenik number gamma")
    ax.set_ylabel("critical contact area a_c*")
    ax.axhline(A_C_STAR_PAPER, color="gray", lw=0.6, ls=":",
               label=f"paper's large-system a_c* = {A_C_STAR_PAPER:g}")
    ax.grid(alpha=0.3)
