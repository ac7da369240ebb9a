"""Fig. 1: height map and fluid channels of an isotropic and a stretched surface."""

from __future__ import annotations

import numpy as np
import xarray as xr
from matplotlib.colors import ListedColormap
from matplotlib.figure import Figure
from matplotlib.patches import Rectangle

from .captions import CAPTIONS

CAPTION = CAPTIONS["channels"]

#: Colours of the phase codes 0 contact, 1 other fluid, 2 fluid percolating along x
#: (percolation.percolation_map): orange, light blue, dark blue as in the paper's Fig. 1.
PHASE_COLORS = ListedColormap(["#f28e2b", "#a6cee3", "#1f3b99"])


def draw(ds: xr.Dataset, fit=None) -> Figure:
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
        ax.imshow(ds[f"phase_{name}"].values.T, origin="lower", cmap=PHASE_COLORS, vmin=-0.5,
                  vmax=2.5, aspect="auto", extent=(0, 1, 0, 1), interpolation="nearest")
        perc = "percolates" if a[f"{name}_fluid_percolates_x"] else "does not percolate"
        ax.set_title(f"{label}: gamma = {a[f'{name}_gamma']:g}, "
                     f"{a[f'{name}_lx']:g} x {a[f'{name}_ly']:g} cell\n"
                     f"a_c = {a[f'{name}_area_fraction']:.3f}; fluid along x {perc}",
                     fontsize=9)
    for ax in axes:
        ax.set_xlabel("x / Lx")
        ax.set_ylabel("y / Ly")
    handles = [Rectangle((0, 0), 1, 1, color=c) for c in PHASE_COLORS.colors]
    fig.legend(handles, ["contact", "other fluid", "fluid percolating along x"],
               loc="outside lower center", ncol=3, fontsize=8, frameon=False)
    return fig
