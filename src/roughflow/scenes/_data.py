"""Helpers to build the self-describing per-job datasets."""

from __future__ import annotations

import numpy as np
import xarray as xr

from .jobs import PARAM_DIMS, SurfaceParams, rnd

AXIS_COORD = ("axis", ["x", "y"], {"long_name": "flow / percolation direction (x = axis 0)"})
INT_FILL = -1


def param_coords(p: SurfaceParams, model: str) -> dict:
    """Length-1 parameter coordinates shared by every per-job dataset."""
    return {
        "model": ("model", [model], {"long_name": "contact model"}),
        "gamma": ("gamma", [rnd(p.gamma)],
                  {"units": "1", "long_name": "Peklenik number (> 1: stretched along x)"}),
        "hurst": ("hurst", [rnd(p.hurst)], {"units": "1", "long_name": "Hurst exponent H"}),
        "eps_t": ("eps_t", [p.eps_t], {
            "units": "1",
            "long_name": "eps_t = max(sqrt(gamma), 1/sqrt(gamma)) lambda_r / L"}),
        "eps_f": ("eps_f", [rnd(p.eps_f)],
                  {"units": "1", "long_name": "eps_f = lambda_s / lambda_r"}),
    }


def expand(values, extra_dims: tuple[str, ...]) -> tuple[tuple[str, ...], np.ndarray]:
    """Array over ``extra_dims`` -> (PARAM_DIMS + extra_dims, array with length-1 axes)."""
    a = np.asarray(values)
    return PARAM_DIMS + extra_dims, a.reshape((1,) * len(PARAM_DIMS) + a.shape)


def var(values, extra_dims: tuple[str, ...], units: str, long_name: str,
        **attrs) -> xr.Variable:
    dims, a = expand(values, extra_dims)
    v = xr.Variable(dims, a, {"units": units, "long_name": long_name, **attrs})
    if np.issubdtype(a.dtype, np.integer) or a.dtype == bool:
        v = xr.Variable(dims, a.astype(np.int32), v.attrs)
        v.encoding = {"_FillValue": np.int32(INT_FILL), "dtype": "int32"}
    return v


def surface_vars(p: SurfaceParams, seed: int) -> dict:
    """Grid and size of the job's surfaces (parameters that are not dimensions)."""
    spec = p.spec(seed)
    return {
        "l_over_lambda_r": var(rnd(p.size), (), "1", "L / lambda_r (L: side of the unit cell)"),
        "nx": var(np.int32(spec.nx), (), "1", "grid points along x"),
        "ny": var(np.int32(spec.ny), (), "1", "grid points along y"),
        "points_per_lambda_s": var(float(p.points_per_lambda_s), (), "1",
                                   "grid points per shortest wavelength"),
    }


def no_fill_on_coords(ds: xr.Dataset) -> xr.Dataset:
    """Float coordinates get no NaN _FillValue when written."""
    for name in ds.coords:
        if ds[name].dtype.kind == "f":
            ds[name].encoding["_FillValue"] = None
    return ds


#: the perimeter constant is calibrated on 4 to 16 points per lambda_s (docs/accuracy.md)
CORRECTION_MIN_POINTS = 4.0


def threshold_values(ds):
    """The a_c* to analyse: perimeter-corrected (first-order grid bias of the elastic
    contact area removed, docs/accuracy.md) where the grid has at least
    :data:`CORRECTION_MIN_POINTS` points per lambda_s, the range the constant is calibrated
    on; the raw ``a_c_star`` elsewhere (at 2 points per lambda_s the correction over-shoots:
    isotropic a_c* 0.385 corrected vs 0.436 raw vs about 0.41 converged)."""
    raw = ds["a_c_star"]
    if "a_c_star_corrected" not in ds or "points_per_lambda_s" not in ds:
        return raw
    fine = ds["points_per_lambda_s"] >= CORRECTION_MIN_POINTS
    corrected = ds["a_c_star_corrected"]
    return xr.where(fine & corrected.notnull(), corrected, raw).transpose(*raw.dims)


def area_values(ds):
    """The contact area to plot sigma against: the perimeter-corrected ``a_c`` where the
    ladder stored one (elastic; the fixed-load correction is calibrated from 2 points per
    lambda_s up, error +0.004 at 2 points, docs/accuracy.md), the raw ``a_c`` elsewhere."""
    raw = ds["area_fraction"]
    if "area_fraction_corrected" not in ds:
        return raw
    corrected = ds["area_fraction_corrected"]
    return xr.where(corrected.notnull(), corrected, raw).transpose(*raw.dims)
