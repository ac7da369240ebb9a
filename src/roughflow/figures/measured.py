"""Measured scans: leak rate and contact area versus nominal contact pressure."""

from __future__ import annotations

import matplotlib as mpl
import numpy as np
import xarray as xr
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from roughflow.defaults import LEAK_MIN_CONTACT_CELLS

from .captions import CAPTIONS

CAPTION = CAPTIONS["measured"]
MARKERS = "osD^v<>p*h"

#: The legend entry of the hollow markers (rows :func:`row_flags` marks).
UNRESOLVED_LABEL = (f"hollow: no contact / fewer than {LEAK_MIN_CONTACT_CELLS} contact cells "
                    "in the window: not resolved")


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


def window_shape(ds: xr.Dataset, k: int) -> tuple[int, int] | None:
    """The analysed window's cells along x and y of scan ``k``: the per-scan ``window_nx``
    and ``window_ny`` variables (aggregated scans that differ in it), else the attributes
    (a leak file, or scans that share it); None where the dataset holds neither."""
    shape = []
    for name in ("window_nx", "window_ny"):
        if name in ds.variables:
            value = _per_scan(ds.isel(scan=k), name)
        else:
            value = float(ds.attrs.get(name, np.nan))
        if not np.isfinite(value) or value < 1:
            return None
        shape.append(int(value))
    return shape[0], shape[1]


def row_flags(ds: xr.Dataset) -> tuple[np.ndarray, np.ndarray]:
    """Per scan and pressure (arrays over ``scan`` x ``pressure``): the rows whose analysed
    window holds no contact cell (the leak table's "*",
    :func:`roughflow.leak.empty_window_rows`) and those with contact on too few cells to
    resolve it ("~", :func:`roughflow.leak.few_cell_rows`). A pressure a scan has no row
    at (NaN: another scan's grid) is in neither; without the window's size no row is in
    the second."""
    # here, not at the top: roughflow.leak loads the solvers (about a second), which
    # importing this module for its CAPTION need not pay for
    from roughflow.leak import empty_window_rows, few_cell_rows

    area = np.asarray(ds["area_fraction"].transpose("scan", "pressure").values, dtype=float)
    empty = np.zeros(area.shape, bool)
    few = np.zeros(area.shape, bool)
    for k in range(area.shape[0]):
        known = np.isfinite(area[k])  # NaN would count as "few" cells once rounded
        empty[k, known] = empty_window_rows(area[k, known])
        shape = window_shape(ds, k)
        if shape is not None:
            few[k, known] = few_cell_rows(area[k, known], shape)
    return empty, few


def draw(ds: xr.Dataset, fit: xr.Dataset | None = None) -> Figure:
    """Left: leak rate per scan (a colour and marker each; flow along x solid, y dashed) and
    the sealing brackets (shaded, hatched for y; a line where it is sealed). Right: a_c.
    Rows :func:`row_flags` marks are hollow markers off the lines. The legend sits below the
    panels, one entry per scan, so that ten scans stay readable."""
    scans = ds["scan"].values
    p = ds["pressure"].values
    bounds = boundaries(ds)
    shared = len(set(bounds)) == 1
    stiff = moduli(ds)
    empty, few = row_flags(ds)
    unresolved = empty | few
    ncol = min(4, max(2, len(scans)))
    # the scans, two line styles, the band, and the hollow markers where there are any
    rows = -(-(len(scans) + 3 + int(unresolved.any())) // ncol)
    fig = Figure(figsize=(10, 4.2 + 0.22 * rows), layout="constrained")
    ax_q, ax_a = fig.subplots(1, 2)
    colors = mpl.rcParams["axes.prop_cycle"].by_key()["color"]
    handles = []
    for k, scan in enumerate(scans):
        d = ds.sel(scan=scan)
        marker, color = MARKERS[k % len(MARKERS)], colors[k % len(colors)]
        notes = ([] if shared else [bounds[k]]) + ([] if stiff is None else [stiff[k]])
        label = f"{scan} ({', '.join(notes)})" if notes else str(scan)
        bad = unresolved[k]
        for axis, style, hatch in (("x", "-", None), ("y", "--", "//")):
            q = d["leak_rate"].sel(axis=axis).values
            leaking = q > 0  # Q = 0 (sealed) is off the log scale; NaN: no row here
            # the line joins the resolved rows only: a flagged row's leak rate is not the
            # seal's (an empty window is held open from outside) or is under-resolved
            ax_q.plot(p[leaking & ~bad], q[leaking & ~bad], style, marker=marker, ms=4,
                      color=color, label=f"{label}, flow along {axis}")
            if (leaking & bad).any():
                ax_q.plot(p[leaking & bad], q[leaking & bad], ls="none", marker=marker,
                          ms=4, mfc="none", color=color,
                          label=f"{label}, flow along {axis}: not resolved")
            lo = _per_scan(d.sel(axis=axis), "sealing_pressure_lo")
            hi = _per_scan(d.sel(axis=axis), "sealing_pressure")
            if np.isfinite(lo) and np.isfinite(hi):
                ax_q.axvspan(lo, hi, facecolor=color, alpha=0.18, hatch=hatch,
                             edgecolor=color, lw=0)
                ax_q.axvline(hi, color=color, ls=style, lw=0.8,
                             label=f"{scan}: sealed along {axis} from {hi:.3g} Pa")
        a = d["area_fraction"].values
        known = np.isfinite(a)
        # unclipped: an empty window's a_c = 0 and a closed one's 1 lie on the panel's edges
        ax_a.plot(p[known & ~bad], a[known & ~bad], "-", marker=marker, ms=4, color=color,
                  label=label, clip_on=False)
        if (known & bad).any():
            ax_a.plot(p[known & bad], a[known & bad], ls="none", marker=marker, ms=4,
                      mfc="none", color=color, label=f"{label}: not resolved", clip_on=False)
        handles.append(Line2D([], [], color=color, marker=marker, ms=4, label=label))
    handles += [Line2D([], [], color="k", ls="-", label="flow along x"),
                Line2D([], [], color="k", ls="--", label="flow along y"),
                Patch(facecolor="0.7", edgecolor="0.4", hatch="//",
                      label="sealing bracket (hatched: y)")]
    if unresolved.any():
        handles.append(Line2D([], [], color="k", ls="none", marker="o", ms=4, mfc="none",
                              label=UNRESOLVED_LABEL))
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


def _sealing_text(ds: xr.Dataset) -> str:
    """Each scan's sealing pressure along x and y (``sealing_pressure``, the lowest nominal
    pressure found sealed, in its unit) where the search bracketed it, "not bracketed"
    where it did not, "not searched" where the leak run skipped it (--no-sealing)."""
    unit = str(ds["sealing_pressure"].attrs.get("units", "Pa"))
    per_scan = []
    for k, scan in enumerate(ds["scan"].values):
        d = ds.isel(scan=k)
        searched = (_per_scan(d, "sealing_searched") if "sealing_searched" in ds.variables
                    else float(ds.attrs.get("sealing_searched", 1)))
        if searched == 0:
            per_scan.append(f"{scan} not searched")
            continue
        axes = []
        for axis in ("x", "y"):
            da = d.sel(axis=axis)
            hi = _per_scan(da, "sealing_pressure")
            # files without ``bracketed``: a finite bracket is a bracketed one
            found = (_per_scan(da, "bracketed") == 1 if "bracketed" in ds.variables
                     else np.isfinite(hi) and np.isfinite(_per_scan(da, "sealing_pressure_lo")))
            axes.append(f"{axis} {hi:.4g} {unit}" if found and np.isfinite(hi)
                        else f"{axis} not bracketed")
        per_scan.append(f"{scan} {' and '.join(axes)}")
    return f"sealing pressure (lowest found sealed): {', '.join(per_scan)}"


def _flag_text(ds: xr.Dataset) -> str:
    """How many rows (scan and pressure) :func:`row_flags` marks, of how many, by scan."""
    empty, few = row_flags(ds)
    scans = [str(s) for s in ds["scan"].values]
    rows = int(np.isfinite(np.asarray(ds["area_fraction"].values, dtype=float)).sum())
    flagged = int((empty | few).sum())
    if not flagged:
        return (f"all {rows} rows resolved (contact on >= {LEAK_MIN_CONTACT_CELLS} cells of "
                "the analysed window)")

    def by_scan(mask: np.ndarray) -> str:
        return ", ".join(f"{s} {int(n)}" for s, n in zip(scans, mask.sum(axis=1), strict=True)
                         if n)

    kinds = []
    if empty.any():
        kinds.append(f"{int(empty.sum())} with no contact cell in the analysed window "
                     f"({by_scan(empty)}; the leak table's '*')")
    if few.any():
        kinds.append(f"{int(few.sum())} with contact on fewer than {LEAK_MIN_CONTACT_CELLS} "
                     f"of its cells ({by_scan(few)}; '~')")
    return (f"{flagged} of {rows} rows not resolved, drawn hollow off the lines: "
            f"{' and '.join(kinds)}")


def summary(ds: xr.Dataset) -> str:
    """What a measured study dataset (or a leak file) holds, for the caption file: its
    scans, their sealing pressures, and how many rows the figure draws as not resolved."""
    scans = [str(s) for s in ds["scan"].values]
    return "; ".join([f"{len(scans)} scan{'s' if len(scans) != 1 else ''} "
                      f"({', '.join(scans)})", _sealing_text(ds), _flag_text(ds)])
