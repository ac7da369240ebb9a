"""Helpers of the conductance figures (Fig. 5-7)."""

from __future__ import annotations

import numpy as np
import xarray as xr
from matplotlib.axes import Axes

from roughflow.defaults import STUDY_ONE_VALUE
from roughflow.errors import InputError


def ladder(ds: xr.Dataset, model: str) -> xr.Dataset:
    """The model's ladder with length-1 parameter dimensions dropped."""
    sub = ds.sel(model=model)
    for dim in STUDY_ONE_VALUE["flow_isotropic"]:  # the same for both flow studies
        if dim in sub.dims:
            # models may run at different sizes (series): keep the entries with data
            other = [d for d in sub["area_fraction"].dims if d != dim]
            ran = sub["area_fraction"].notnull().any(other).values
            if ran.sum() != 1 and sub.sizes[dim] != 1:
                raise InputError(f"the flow figures expect one {dim} per model, got "
                                 f"{sub[dim].values[ran]}")
            sub = sub.isel({dim: int(np.argmax(ran)) if ran.any() else 0})
    return sub


def sigma_ref(sub: xr.Dataset) -> float:
    """Full Reynolds conductance at a_c -> 0+, averaged over seeds and directions."""
    return float(sub["sigma_ref"].mean(skipna=True))


def curve(a_c: xr.DataArray, y: xr.DataArray) -> tuple[np.ndarray, np.ndarray]:
    """Seed-averaged (a_c, y) along the ladder, positive y only (for log axes)."""
    x = a_c.mean("seed", skipna=True).values
    v = y.mean("seed", skipna=True).values
    ok = np.isfinite(x) & np.isfinite(v) & (v > 0)
    return x[ok], v[ok]


def points(a_c: xr.DataArray, y: xr.DataArray) -> tuple[np.ndarray, np.ndarray]:
    """Every seed's (a_c, y), positive y only."""
    x, v = np.broadcast_arrays(a_c.values, y.values)
    x, v = x.ravel(), v.ravel()
    ok = np.isfinite(x) & np.isfinite(v) & (v > 0)
    return x[ok], v[ok]


def sealed(a_c: xr.DataArray, sigma: xr.DataArray) -> np.ndarray:
    """The a_c of every seed and step whose conductance is exactly 0: the fluid no longer
    percolates (the flow solver returns 0 without a solve there), which a log axis cannot
    show."""
    x, v = np.broadcast_arrays(a_c.values, sigma.values)
    x, v = x.ravel(), v.ravel()
    return x[np.isfinite(x) & (v == 0)]


def mark_edge(ax: Axes, x: np.ndarray, *, color: str, label: str, top: bool = False) -> None:
    """Triangles on the bottom (``top``: the top) edge of ``ax`` at ``x``: values off its
    log scale (a conductance of 0, a ratio over 0), said in the legend instead of dropped
    without a word."""
    if not len(x):
        return
    ax.plot(x, np.full(len(x), 1.0 if top else 0.0), "^" if top else "v", color=color,
            mfc=color, ms=5, clip_on=False, transform=ax.get_xaxis_transform(), label=label)
