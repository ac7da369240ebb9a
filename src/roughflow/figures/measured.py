"""Measured scans: leak rate and contact area versus nominal contact pressure."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from .captions import CAPTIONS

CAPTION = CAPTIONS["measured"]
MARKERS = "osD^v<>p*h"


def _per_scan(d: xr.Dataset, name: str) -> float:
    """The value of a per-scan variable of one scan (and axis); a dataset written before
    per-scan variables kept their dimensions has them over ``pressure`` too, with NaN
    where the scan has no pressure: the value is the one finite there."""
    v = np.asarray(d[name].values, dtype=float).ravel()
    v = v[np.isfinite(v)]
    return float(v[0]) if v.size else np.nan


def boundaries(ds: xr.Dataset) -> list[str]:
    """The boundary treatment of each scan: the per-scan ``boundary`` variable of a study
    dataset, else the ``boundary`` attribute (a leak file), else "unknown"."""
    n = ds.sizes["scan"]
    if "boundary" in ds.variables:
        return [str(b) or "unknown" for b in np.asarray(ds["boundary"].values).ravel()]
    return [str(ds.attrs.get("boundary", "unknown"))] * n


def moduli(ds: xr.Dataset) -> list[str] | None:
    """Each scan's contact modulus E* for the legend where the scans differ in it (faces of
    different materials), else None."""
    if "modulus" not in ds.variables or ds["modulus"].ndim != 1:
        return None
    values = np.asarray(ds["modulus"].values, dtype=float)
    if len(set(values.tolist())) < 2:
        return None
    return [f"E* = {v / 1e9:.3g} GPa" for v in values]


def draw(ds: xr.Dataset, fit: xr.Dataset | None = None) -> plt.Figure:
    """Left: leak rate per scan (a colour and marker each; flow along x solid, y dashed) and
    the sealing brackets (shaded, hatched for y; a line where it is sealed). Right: a_c. The
    legend sits below the panels, one entry per scan, so that ten scans stay readable."""
    scans = ds["scan"].values
    p = ds["pressure"].values
    bounds = boundaries(ds)
    shared = len(set(bounds)) == 1
    stiff = moduli(ds)
    ncol = min(4, max(2, len(scans)))
    rows = -(-(len(scans) + 3) // ncol)  # the scans, two line styles and the band
    fig, (ax_q, ax_a) = plt.subplots(1, 2, figsize=(10, 4.2 + 0.22 * rows),
                                     layout="constrained")
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    handles = []
    for k, scan in enumerate(scans):
        d = ds.sel(scan=scan)
        marker, color = MARKERS[k % len(MARKERS)], colors[k % len(colors)]
        notes = ([] if shared else [bounds[k]]) + ([] if stiff is None else [stiff[k]])
        label = f"{scan} ({', '.join(notes)})" if notes else str(scan)
        for axis, style, hatch in (("x", "-", None), ("y", "--", "//")):
            q = d["leak_rate"].sel(axis=axis).values
            leaking = q > 0
            ax_q.plot(p[leaking], q[leaking], style, marker=marker, ms=4, color=color,
                      label=f"{label}, flow along {axis}")
            lo = _per_scan(d.sel(axis=axis), "sealing_pressure_lo")
            hi = _per_scan(d.sel(axis=axis), "sealing_pressure")
            if np.isfinite(lo) and np.isfinite(hi):
                ax_q.axvspan(lo, hi, facecolor=color, alpha=0.18, hatch=hatch,
                             edgecolor=color, lw=0)
                ax_q.axvline(hi, color=color, ls=style, lw=0.8,
                             label=f"{scan}: sealed along {axis} from {hi:.3g} Pa")
        a = d["area_fraction"].values
        known = np.isfinite(a)
        ax_a.plot(p[known], a[known], "-", marker=marker, ms=4, color=color, label=label)
        handles.append(Line2D([], [], color=color, marker=marker, ms=4, label=label))
    handles += [Line2D([], [], color="k", ls="-", label="flow along x"),
                Line2D([], [], color="k", ls="--", label="flow along y"),
                Patch(facecolor="0.7", edgecolor="0.4", hatch="//",
                      label="sealing bracket (hatched: y)")]
    ax_q.set_xscale("log")
    ax_q.set_yscale("log")
    ax_q.set_xlabel("nominal contact pressure [Pa]")
    ax_q.set_ylabel("leak rate Q [m$^3$/s]")
    ax_q.set_title(f"boundary: {bounds[0]}" if shared else
                   "boundary: differs between scans (in the legend)", fontsize=9)
    ax_q.grid(alpha=0.3, which="both")
    ax_a.set_xscale("log")
    ax_a.set_ylim(0, 1)
    ax_a.set_xlabel("nominal contact pressure [Pa]")
    ax_a.set_ylabel("relative contact area a_c")
    ax_a.grid(alpha=0.3, which="both")
    fig.legend(handles=handles, loc="outside lower center", ncol=ncol, fontsize=8,
               frameon=False)
    return fig
