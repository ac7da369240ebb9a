"""Fig. 6-7: sigma_x, sigma_y versus a_c for gamma = 2, elastic and bearing; the ratio."""

from __future__ import annotations

import xarray as xr
from matplotlib.figure import Figure
from matplotlib.ticker import LogFormatter

from roughflow.datasets.sweep import area_values

from ._flow import Row, curve, grid, mark_edge, not_run, points, rows, sealed, sigma_ref, tag
from ._style import EASY, HARD
from .captions import CAPTIONS

CAPTION = CAPTIONS["flow_anisotropic"]
MODEL_MARKER = {"elastic": "o", "bearing": "s", "adhesive": "^"}


def draw(ds: xr.Dataset, fit: xr.Dataset | None = None) -> Figure:
    models = [m for m in ("elastic", "bearing", "adhesive") if m in ds["model"].values]
    n = len(models) + 1
    table = rows(ds, models)
    fig = Figure(figsize=(4.6 * n, 4.2 * len(table)), layout="constrained")
    for i, (row, axes) in enumerate(zip(table, grid(fig, table, n), strict=True)):
        _row(row, axes, models, i, len(table))
    return fig


def _row(row: Row, axes: list, models: list[str], i: int, nrows: int) -> None:
    """One row: a panel per model (sigma_x, sigma_y) and the ratio panel."""
    rax = axes[-1]
    gammas = []
    for j, (ax, model) in enumerate(zip(axes[:-1], models, strict=True)):
        if model not in row.ladders:
            not_run(ax, model)
            continue
        sub = row.ladders[model]
        gamma = float(sub["gamma"])
        gammas.append(gamma)
        ref = sigma_ref(sub)
        a = area_values(sub)
        emt = sub["sigma_emt"]
        for axis, color in (("x", EASY), ("y", HARD)):
            x, y = points(a, sub["sigma"].sel(axis=axis) / ref)
            ax.plot(x, y, MODEL_MARKER[model], mfc="white", color=color,
                    label=f"Reynolds sigma_{axis}")
            mark_edge(ax, sealed(a, sub["sigma"].sel(axis=axis)), color=color,
                      label=f"sealed along {axis} (sigma_{axis} = 0)")
            x, y = curve(a, emt.sel(emt="anisotropic_corrected", axis=axis) / ref)
            ax.plot(x, y, "-", color=color, label=f"Bruggeman Eq. 9, {axis}")
            x, y = curve(a, emt.sel(emt="anisotropic_persson", axis=axis) / ref)
            ax.plot(x, y, "--", color=color, lw=0.8, label=f"Persson Eq. 7, {axis}")
        x, y = curve(a, emt.sel(emt="isotropic", axis="x") / ref)
        ax.plot(x, y, ":", color="gray", label="isotropic Bruggeman")
        ax.set_yscale("log")
        ax.set_xlabel("relative contact area a_c")
        ax.set_ylabel("sigma / sigma_ref")
        ax.set_title(f"{tag(j, i, nrows)} {model}, gamma = {gamma:g}", fontsize=10)
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=6.5)
        # ratio panel
        sx, sy = sub["sigma"].sel(axis="x"), sub["sigma"].sel(axis="y")
        ratio = (sx / sy.where(sy > 0))
        x, y = points(a, ratio)
        rax.plot(x, y, MODEL_MARKER[model], mfc="white", color="k",
                 label=f"Reynolds, {model}")
        # sealed along y only: chi is infinite
        mark_edge(rax, sealed(a, sy.where(sx > 0)), color="k" if model == "elastic" else "gray",
                  label=f"sigma_y = 0 < sigma_x, {model}", top=True)
        ex = emt.sel(emt="anisotropic_corrected", axis="x")
        ey = emt.sel(emt="anisotropic_corrected", axis="y")
        x, y = curve(a, ex / ey.where(ey > 0))
        rax.plot(x, y, "-", lw=1, label=f"Bruggeman Eq. 9, {model}",
                 color="tab:blue" if model == "elastic" else "tab:orange")
    # the limit chi -> gamma^2 at a_c -> 0; models at different gammas: one line each
    shown = sorted(set(gammas))
    for gamma in shown:
        rax.axhline(gamma**2, color="gray", ls=":",
                    label="gamma^2" if len(shown) == 1 else f"gamma^2, gamma = {gamma:g}")
    rax.set_yscale("log")
    # chi spans about one decade, where matplotlib labels the minor ticks too: plain
    # numbers instead of "2 x 10^0"
    rax.yaxis.set_major_formatter(LogFormatter())
    rax.yaxis.set_minor_formatter(LogFormatter())
    rax.set_xlabel("relative contact area a_c")
    rax.set_ylabel("chi = sigma_x / sigma_y")
    rax.set_title(f"{tag(len(models), i, nrows)} conductance ratio", fontsize=10)
    rax.grid(alpha=0.3, which="both")
    rax.legend(fontsize=6.5)
