"""Shared plotting helpers: colours of the paper (easy/stretching blue, hard red)."""

from __future__ import annotations

import numpy as np
import xarray as xr

EASY = "tab:blue"
HARD = "tab:red"
AXIS_COLOR = {"x": EASY, "y": HARD}


def seed_stats(da: xr.DataArray) -> tuple[xr.DataArray, xr.DataArray, xr.DataArray]:
    """Mean, standard error and count over the seed dimension (NaN = not run). A point
    with one seed has no standard error (NaN: no error bar), not a zero one, which drew it
    as more certain than a point of ten seeds."""
    n = da.notnull().sum("seed")
    mean = da.mean("seed", skipna=True)
    std = (da.std("seed", skipna=True, ddof=1) if da.sizes["seed"] > 1
           else xr.full_like(mean, np.nan))
    sem = std / np.sqrt(n.where(n > 1))
    return mean, sem, n


def setting_text(a: xr.DataArray) -> str:
    """The single model, H and eps_f of a series (those of its coordinates that are scalar;
    a panel whose legend names several values leaves that dimension in ``a``), for a
    panel's title: the captions quote the paper's values, the data may hold others."""
    parts = []
    if "model" in a.coords and a["model"].ndim == 0:
        parts.append(f"{a['model'].item()} contact")
    if "hurst" in a.coords and a["hurst"].ndim == 0:
        parts.append(f"H = {float(a['hurst']):g}")
    if "eps_f" in a.coords and a["eps_f"].ndim == 0:
        parts.append(f"eps_f = 1/{1 / float(a['eps_f']):.3g}")
    return ", ".join(parts)
