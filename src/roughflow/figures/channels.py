"""Fig. 1: height map and fluid channels of an isotropic and a stretched surface."""

from __future__ import annotations

import numpy as np
import xarray as xr
from matplotlib.colors import ListedColormap
from matplotlib.figure import Figure
from matplotlib.patches import Rectangle

from roughflow.percolation.clusters import PHASE_NAMES

from .captions import CAPTIONS

CAPTION = CAPTIONS["channels"]

#: Colour and legend of each phase, by its name in the phase map's ``flag_meanings``:
#: orange, light blue, dark blue as in the paper's Fig. 1.
PHASES = {"contact": ("#f28e2b", "contact"),
          "non_percolating_fluid": ("#a6cee3", "other fluid"),
          "percolating_fluid": ("#1f3b99", "fluid percolating along x")}


def phase_colors(phase: xr.DataArray) -> ListedColormap:
    """Colours of the codes 0, 1, 2 of ``phase`` read from its ``flag_meanings``, so that a
    file written with another order of codes (before the scene used percolation_map's, 1
    meant percolating) is drawn right."""
    if "flag_meanings" in phase.attrs:
        meanings = str(phase.attrs["flag_meanings"]).split()
        values = [int(v) for v in np.atleast_1d(phase.attrs["flag_values"])]
        by_code = dict(zip(values, meanings, strict=True))
    else:  # percolation_map's codes
        by_code = PHASE_NAMES
    return ListedColormap([PHASES[by_code[code]][0] for code in range(3)])


def draw(ds: xr.Dataset, fit: xr.Dataset | None = None) -> Figure:
    fig = Figure(figsize=(12, 4.6), layout="constrained")
    axes = fig.subplots(1, 3)
    h = ds["heights_iso"].values
    im = axes[0].imshow((h / np.abs(h).max()).T, origin="lower", cmap="viridis",
                        aspect="auto", extent=(0, 1, 0, 1))
    fig.colorbar(im, ax=axes[0], shrink=0.8, label="h / max|h|")
    axes[0].set_title(f"(a) height, {ds.attrs['iso_lx']:g} x {ds.attrs['iso_ly']:g} "
                      f"(gamma = 1) = 1 x 1 (gamma = {ds.attrs['gamma']:g})", fontsize=9)
    for ax, name, label in ((axes[1], "iso", "(b) isotropic"), (axes[2], "aniso",
                                                                "(c) anisotropic")):
        a = ds.attrs
        phase = ds[f"phase_{name}"]
        ax.imshow(phase.values.T, origin="lower", cmap=phase_colors(phase), vmin=-0.5,
                  vmax=2.5, aspect="auto", extent=(0, 1, 0, 1), interpolation="nearest")
        perc = "percolates" if a[f"{name}_fluid_percolates_x"] else "does not percolate"
        ax.set_title(f"{label}: gamma = {a[f'{name}_gamma']:g}, "
                     f"{a[f'{name}_lx']:g} x {a[f'{name}_ly']:g} cell\n"
                     f"a_c = {a[f'{name}_area_fraction']:.3f}; fluid along x {perc}",
                     fontsize=9)
    for ax in axes:
        ax.set_xlabel("x / Lx")
        ax.set_ylabel("y / Ly")
    handles = [Rectangle((0, 0), 1, 1, color=c) for c, _ in PHASES.values()]
    fig.legend(handles, [label for _, label in PHASES.values()],
               loc="outside lower center", ncol=3, fontsize=8, frameon=False)
    return fig
