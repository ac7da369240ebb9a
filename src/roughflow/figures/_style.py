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
