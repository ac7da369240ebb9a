"""Shared plotting helpers: colours of the paper (easy/stretching blue, hard red)."""

from __future__ import annotations

import numpy as np
import xarray as xr

EASY = "tab:blue"
HARD = "tab:red"
AXIS_COLOR = {"x": EASY, "y": HARD}


def seed_stats(da: xr.DataArray) -> tuple[xr.DataArray, xr.DataArray, xr.DataArray]:
    """Mean, standard error and count over the seed dimension (NaN = not run)."""
    n = da.notnull().sum("seed")
    mean = da.mean("seed", skipna=True)
    std = da.std("seed", skipna=True, ddof=1) if da.sizes["seed"] > 1 else xr.zeros_like(mean)
    sem = std / np.sqrt(n.where(n > 0))
    return mean, sem.fillna(0.0), n


def one(ds: xr.Dataset, dim: str, value=None) -> xr.Dataset:
    """Select ``value`` along ``dim`` (the only value when None)."""
    if dim not in ds.dims:
        return ds
    if value is None:
        if ds.sizes[dim] != 1:
            raise ValueError(f"expected one {dim}, got {ds[dim].values}")
        return ds.isel({dim: 0})
    return ds.sel({dim: value})


def squeeze_params(ds: xr.Dataset, keep: tuple[str, ...]) -> xr.Dataset:
    """Drop length-1 parameter dimensions not in ``keep``."""
    for dim in ("model", "gamma", "hurst", "eps_t", "eps_f"):
        if dim in ds.dims and dim not in keep and ds.sizes[dim] == 1:
            ds = ds.isel({dim: 0})
    return ds
