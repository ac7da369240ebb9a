"""Plot of the Reynolds flux magnitude of one flow solve over the contact map (``roughflow
flow --plot``)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from numpy.typing import ArrayLike

    from roughflow.flow import FlowResult

__all__ = ["plot_flux"]


def plot_flux(result: FlowResult, contact_mask: ArrayLike | None = None, ax: Axes | None = None,
              *, log: bool = True) -> Axes:
    """Draw |j| of ``result`` (log scale, 6 decades, by default) with contact cells in black.

    ``contact_mask``: boolean (nx, ny) array of contact cells drawn black; cells
    without flow (isolated pools) are left white; a key below the map names both. Axis 0
    (x) is drawn horizontally, over the domain's lengths ``result.lx`` x ``result.ly``
    (units of L) rather than grid cells: an anisotropic surface's grid has cells longer
    along x than along y (gamma > 1), and drawn in cells its square domain would show as a
    strip.
    Returns the matplotlib ``Axes``. Uses whatever backend is active (Agg in scripts).
    """
    import matplotlib.pyplot as plt
    from matplotlib.colors import ListedColormap, LogNorm

    if ax is None:
        _, ax = plt.subplots(figsize=(5, 4.6))
    mag = np.hypot(result.flux_x, result.flux_y)
    extent = (0.0, result.lx, 0.0, result.ly)
    shown = np.ma.masked_where(mag <= 0, mag)
    norm = None
    if log and shown.count() > 0:
        vmax = float(shown.max())
        norm = LogNorm(vmin=max(float(shown.min()), vmax * 1e-6), vmax=vmax)
    im = ax.imshow(shown.T, origin="lower", extent=extent, cmap="viridis", norm=norm,
                   interpolation="nearest")
    if contact_mask is not None:
        c = np.ma.masked_where(~np.asarray(contact_mask, bool), np.ones(mag.shape))
        ax.imshow(c.T, origin="lower", extent=extent, cmap=ListedColormap(["black"]),
                  interpolation="nearest")
    ax.figure.colorbar(im, ax=ax, label="|flux| (u^3 dp / (eta L))")
    # the two colours outside the colour bar, which a reader had to guess (the map's low
    # end is near-black too)
    from matplotlib.patches import Patch

    keys = [Patch(facecolor="white", edgecolor="0.5", label="no flow (isolated pools)")]
    if contact_mask is not None:
        keys.insert(0, Patch(facecolor="black", label="contact"))
    ax.legend(handles=keys, loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=len(keys),
              frameon=False, fontsize="small")
    ax.set_xlabel("x / L")
    ax.set_ylabel("y / L")
    ax.set_title(f"flow along {'xy'[result.axis]}: sigma = {result.sigma:.4g}")
    return ax
