"""a_c* versus gamma, shared by Fig. 2 and Fig. 4."""

from __future__ import annotations

import textwrap

import numpy as np
import xarray as xr
from matplotlib.figure import Figure

from roughflow.datasets.sweep import unbracketed_searches
from roughflow.defaults import A_C_STAR_BEARING, A_C_STAR_PAPER
from roughflow.errors import InputError
from roughflow.fits import direction_names

from ._style import EASY, HARD, seed_stats


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
    """a_c*(gamma) in the easy (blue) and hard (red) directions: seed mean +- standard
    error. The easy direction is x for gamma > 1 and y for gamma < 1
    (:func:`roughflow.fits.direction_names`, as the fits take it): a curve per axis joined
    the hard and the easy value across gamma = 1 under one colour and name.

    ``a`` has dims (gamma, seed, axis); gammas without data are skipped.
    """
    mean, sem, n = seed_stats(a)
    gammas = a["gamma"].values
    below = bool((gammas < 1).any())
    for direction, color in (("easy", EASY), ("hard", HARD)):
        axes = ["x" if direction_names(float(g))["x"] == direction else "y" for g in gammas]
        m = np.array([float(mean.sel(gamma=g, axis=x)) for g, x in zip(gammas, axes,
                                                                       strict=True)])
        s = np.array([float(sem.sel(gamma=g, axis=x)) for g, x in zip(gammas, axes,
                                                                      strict=True)])
        ok = np.isfinite(m)
        if not ok.any():
            continue
        g = gammas[ok] * (offset if direction == "easy" else 1 / offset)
        which = (f"{direction} (x for gamma > 1, y below)" if direction == "easy" and below
                 else f"{direction} (y for gamma > 1, x below)" if below
                 # isotropic surfaces alone have no easy and hard direction
                 else ("x" if direction == "easy" else "y") if np.allclose(gammas, 1.0)
                 else f"{'x' if direction == 'easy' else 'y'} ({direction})")
        ax.errorbar(g, m[ok], yerr=s[ok], marker=marker, ls="-", lw=0.8, color=color,
                    mfc=color if filled else "white", ms=6, capsize=2,
                    label=f"{label} {which}".strip())


def no_data(ax, what: str = "no finite a_c* in the data") -> None:
    """Say on an empty panel that it is empty (an empty axis read as a drawing error)."""
    ax.text(0.5, 0.5, what, transform=ax.transAxes, ha="center", va="center", fontsize=9,
            color="gray")


def note_unbracketed(fig: Figure, ds: xr.Dataset) -> None:
    """Say above the panels how many searches of ``ds`` did not bracket a_c*: their seeds
    are missing from the means (and the fits), which is drawn as any other point."""
    failed, ran = unbracketed_searches(ds)
    if failed:
        text = (f"{failed} of {ran} threshold searches (seed and axis) did not bracket a_c* "
                "and are left out of the seed means and fits (the job logs say why)")
        # wrapped to the figure's width (about 14 characters an inch at 8 points)
        fig.suptitle(textwrap.fill(text, int(14 * fig.get_figwidth())), color="tab:red",
                     fontsize=8)


def reference_threshold(model: str) -> tuple[float, str]:
    """The reference a_c* of a threshold panel of ``model`` and its legend label: the
    bearing model's exact 1/2, else the paper's elastic large-system value."""
    if model == "bearing":
        return A_C_STAR_BEARING, f"bearing model's exact isotropic a_c* = {A_C_STAR_BEARING:g}"
    return A_C_STAR_PAPER, f"paper's large-system elastic a_c* = {A_C_STAR_PAPER:g}"


def format_gamma_axis(ax, gammas, model: str) -> None:
    ax.set_xscale("log")
    # a fixed margin: with one gamma, autoscaling spread the few-percent nudges that keep
    # the series apart over the whole panel, as if they were other gammas
    ax.set_xlim(min(gammas) / 1.3, max(gammas) * 1.3)
    ax.set_xticks(list(gammas))
    ax.set_xticklabels([f"{g:g}" for g in gammas])
    ax.minorticks_off()
    ax.set_xlabel("Peklenik number gamma")
    ax.set_ylabel("critical contact area a_c*")
    reference, label = reference_threshold(model)
    ax.axhline(reference, color="gray", lw=0.6, ls=":", label=label)
    ax.grid(alpha=0.3)
