"""Fig. 3: size dependence of a_c* and the finite-size-scaling fits."""

from __future__ import annotations

import textwrap

import numpy as np
import xarray as xr
from matplotlib.figure import Figure

from roughflow.datasets.sweep import single_setting, threshold_values
from roughflow.defaults import NU_PERCOLATION
from roughflow.errors import InputError
from roughflow.fits import direction_names, fitted_setting, main_gamma, scaling

from ._style import EASY, HARD, seed_stats, setting_text
from ._threshold import no_data, note_unbracketed
from .captions import CAPTIONS

CAPTION = CAPTIONS["threshold_vs_size"]


def _nu_text(nu: float) -> str:
    """The fixed exponent as the legend shows it: 4/3 by name, any other by value."""
    return "4/3" if np.isclose(nu, NU_PERCOLATION) else f"{nu:.3g}"


def _fit_row(fit: xr.Dataset, group: str, which: str, mode: str) -> dict | None:
    if fit is None or group not in fit["group"].values:
        return None
    row = fit.sel(group=group, fit=which, nu_mode=mode)
    if not np.isfinite(float(row["a_star"])):
        return None
    return {k: float(row[k]) for k in row.data_vars}


#: Characters of a line of the fitted values below the plot (7 pt on a 6.4 inch figure).
TEXT_WIDTH = 100


def _err(row: dict) -> str:
    """a_c*'s error, and where the law misses the data (``lack_of_fit``) by how much: the
    error measures the seeds' scatter only."""
    text = f" +- {row['a_star_err']:.3f}" if np.isfinite(row["a_star_err"]) else ""
    if row.get("lack_of_fit"):
        text += f" (the law misses the seed means: chi2/dof {row['chi2_dof']:.2g})"
    return text


def draw(ds: xr.Dataset, fit: xr.Dataset | None = None) -> Figure:
    # the fitted values go below the plot: inside it, their box hid data points
    fig = Figure(figsize=(6.4, 5.6), layout="constrained")
    ax, box = fig.subplots(2, 1, height_ratios=(4.8, 0.8))
    box.axis("off")
    a = single_setting(threshold_values(ds))  # the fits' check: one model, hurst, eps_f
    if fit is not None:  # a fit of another series drew its lines through these points
        mine = fitted_setting(a)
        other = {k: v for k, v in fit.attrs.items() if k.startswith("fitted_")}
        differ = [f"{k[7:]} {other[k]} (fit) against {mine[k]} (data)" for k in other
                  if k in mine and other[k] != mine[k]]
        if differ:
            raise InputError("the fit file fitted another series: " + ", ".join(differ))
    mean, sem, _ = seed_stats(a)
    gammas = [float(g) for g in a["gamma"].values]
    main = main_gamma(a)  # the series the anisotropic fits take
    aniso = [g for g in gammas if not np.isclose(g, 1.0)]
    eps_max = 0.0
    for g in gammas:
        names = direction_names(g)  # x is easy for gamma > 1, y below (as the fits take it)
        for axis in ("x", "y"):
            color = EASY if names[axis] == "easy" else HARD
            m = mean.sel(gamma=g, axis=axis)
            ok = np.isfinite(m.values)
            if not ok.any():
                continue
            e = a["eps_t"].values[ok]
            eps_max = max(eps_max, e.max())
            s = sem.sel(gamma=g, axis=axis).values[ok]
            if np.isclose(g, 1.0):
                ax.errorbar(e, m.values[ok], yerr=s, marker="x", color="k", ls="none",
                            capsize=2, label="isotropic" if axis == "x" else None)
            else:
                marker = "o" if g == main else "^"
                # the other gammas may lie on both sides of 1: their entry names the
                # direction, whose colour they share, not an axis
                lab = (f"gamma = {g:g}, {axis} ({names[axis]})" if g == main
                       else (f"other gamma, {names[axis]} (not fitted)"
                             if g == min(set(aniso) - {main}) else None))
                ax.errorbar(e, m.values[ok], yerr=s, marker=marker, color=color, ls="none",
                            mfc="white" if marker == "o" else color, capsize=2, label=lab)
                if g != main:
                    for ei, mi in zip(e, m.values[ok], strict=True):
                        ax.annotate(f"{g:g}", (ei, mi), textcoords="offset points",
                                    xytext=(4, 2), fontsize=6, color=color)
    eps = np.linspace(0.0, 1.05 * max(eps_max, 1e-3), 200)
    lines = []
    for mode, ls in (("fixed", "-"), ("free", "--")):
        row = _fit_row(fit, "anisotropic", "joint", mode)
        if row is not None:
            ax.plot(eps, scaling(eps, row["a_star"], row["amp_easy"], row["nu"]), color=EASY,
                    ls=ls, lw=1)
            ax.plot(eps, scaling(eps, row["a_star"], row["amp_hard"], row["nu"]), color=HARD,
                    ls=ls, lw=1)
            nu_err = f" +- {row['nu_err']:.2f}" if np.isfinite(row["nu_err"]) else ""
            bound = " (at its bound: not determined)" if row.get("nu_at_bound") else ""
            lines.append(f"joint, nu {mode}: a_c* = {row['a_star']:.3f}{_err(row)}, "
                         f"nu = {row['nu']:.2f}{nu_err if mode == 'free' else ''}{bound}")
            if mode == "fixed" and np.isfinite(row["a_star_err"]):
                ax.axhspan(row["a_star"] - row["a_star_err"], row["a_star"] + row["a_star_err"],
                           color="gray", alpha=0.2, lw=0)
        for which in ("easy", "hard"):
            r = _fit_row(fit, "anisotropic", which, mode)
            if r is not None and mode == "fixed":
                lines.append(f"{which} alone, nu {_nu_text(r['nu'])}: "
                             f"a_c* = {r['a_star']:.3f}{_err(r)}")
    iso = _fit_row(fit, "isotropic", "joint", "fixed")
    if iso is not None:
        ax.plot(eps, scaling(eps, iso["a_star"], iso["amp_easy"], iso["nu"]), color="k",
                lw=0.8, ls=":")
        lines.append(f"isotropic, nu {_nu_text(iso['nu'])}: a_c* = {iso['a_star']:.3f}"
                     f"{_err(iso)}")
    if fit is not None and not lines:
        lines.append("fit not determined (too few sizes or seeds: see the fit's log)")
    if lines:
        # wrapped to the panel's width, which sets its height: one long line (a lack-of-fit
        # note) squeezed the plot to half the figure's width and was still cut off
        wrapped = [w for line in lines for w in textwrap.wrap(line, TEXT_WIDTH,
                                                               subsequent_indent="    ")]
        ax.get_gridspec().set_height_ratios((4.8, 0.14 * len(wrapped) + 0.1))
        fig.set_figheight(4.9 + 0.14 * len(wrapped))
        box.text(0.0, 1.0, "\n".join(wrapped), transform=box.transAxes, fontsize=7, va="top")
    if eps_max == 0.0:
        no_data(ax)
    ax.set_title(setting_text(a), fontsize=9)
    ax.set_xlim(0, eps[-1])
    ax.set_xlabel("eps_t = max(sqrt(gamma), 1/sqrt(gamma)) lambda_r / L")
    ax.set_ylabel("critical contact area a_c*")
    ax.grid(alpha=0.3)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=7, loc="upper left")
    note_unbracketed(fig, ds)
    return fig
