"""a_c* versus gamma, shared by Fig. 2 and Fig. 4."""

from __future__ import annotations

import numpy as np
import xarray as xr

from roughflow.defaults import A_C_STAR_PAPER

from ._style import AXIS_COLOR, seed_stats


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
    ax.axhline(A_C_STAR_PAPER, color="gray", lw=0.6, ls=":")
    ax.grid(alpha=0.3)
