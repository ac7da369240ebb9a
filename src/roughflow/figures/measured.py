"""Measured scans: leak rate and contact area versus nominal contact pressure."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr

from ._style import AXIS_COLOR

CAPTION = (
    "Leak rate Q of a seal versus the nominal contact pressure for each measured scan "
    "(roughflow import + roughflow leak; docs/measured.md): flow along x (solid) and y "
    "(dashed) for the seal width, length, fluid pressure drop and viscosity of the config. "
    "Q = 0 once the fluid no longer percolates; the shaded bands mark each scan's sealing "
    "pressure along x and y (between the highest pressure found leaking and the lowest found "
    "sealed). Right: the relative contact area a_c. The non-periodic treatment of the scans "
    "is in the dataset's 'boundary' attribute."
)
MARKERS = "osD^v<>p*h"


def draw(ds: xr.Dataset, fit=None) -> plt.Figure:
    fig, (ax_q, ax_a) = plt.subplots(1, 2, figsize=(10, 4.2), constrained_layout=True)
    p = ds["pressure"].values
    for k, scan in enumerate(ds["scan"].values):
        d = ds.sel(scan=scan)
        marker = MARKERS[k % len(MARKERS)]
        for axis, style in (("x", "-"), ("y", "--")):
            q = d["leak_rate"].sel(axis=axis).values
            leaking = q > 0
            ax_q.plot(p[leaking], q[leaking], style, marker=marker, ms=4,
                      color=AXIS_COLOR[axis], label=f"{scan}, flow along {axis}")
            lo = float(d["sealing_pressure_lo"].sel(axis=axis))
            hi = float(d["sealing_pressure"].sel(axis=axis))
            if np.isfinite(lo) and np.isfinite(hi):
                ax_q.axvspan(lo, hi, color=AXIS_COLOR[axis], alpha=0.25)
                ax_q.axvline(hi, color=AXIS_COLOR[axis], ls=style, lw=0.8,
                             label=f"{scan}: sealed along {axis} from {hi:.3g} Pa")
        ax_a.plot(p, d["area_fraction"].values, "-", marker=marker, ms=4, color="k",
                  label=str(scan))
    ax_q.set_xscale("log")
    ax_q.set_yscale("log")
    ax_q.set_xlabel("nominal contact pressure [Pa]")
    ax_q.set_ylabel("leak rate Q [m$^3$/s]")
    ax_q.set_title(f"boundary: {ds.attrs.get('boundary', 'per scan')}", fontsize=9)
    ax_q.grid(alpha=0.3, which="both")
    ax_q.legend(fontsize=7)
    ax_a.set_xscale("log")
    ax_a.set_ylim(0, 1)
    ax_a.set_xlabel("nominal contact pressure [Pa]")
    ax_a.set_ylabel("relative contact area a_c")
    ax_a.grid(alpha=0.3, which="both")
    ax_a.legend(fontsize=7)
    return fig
