"""Layout of the sweep's per-job datasets, and the values that analyses read from them.

Every job dataset has the length-1 parameter dimensions :data:`PARAM_DIMS` (filled by the
aggregation over jobs) followed by the job's own dimensions (seed, axis, step, ...).
Parameter values are rounded to 12 significant digits (:func:`rnd`), so that values
computed in different jobs land on one coordinate.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import xarray as xr

from roughflow.defaults import CORRECTION_MIN_POINTS, STUDY_ONE_VALUE
from roughflow.errors import InputError

from .results import AXIS_COORD
from .units import DIMENSIONLESS, INT_FILL, LENGTH_UNITS, flags

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from roughflow.scenes.jobs import SurfaceParams

#: Dimensions of every per-job dataset (length 1 in a job, filled by the aggregation).
PARAM_DIMS = ("model", "gamma", "hurst", "eps_t", "eps_f")

__all__ = ["AXIS_COORD", "CORRECTION_MIN_POINTS", "INT_FILL", "PARAM_DIMS", "area_values",
           "corrected_taken", "expand", "fine_grid", "no_fill_on_coords", "param_coords",
           "param_key", "rnd", "seed_coord", "surface_vars", "threshold_values", "var"]


def rnd(v: float) -> float:
    """``v`` rounded to 12 significant digits (stable coordinate values across jobs)."""
    return float(f"{float(v):.12g}")


def param_key(p: SurfaceParams, model: str) -> tuple:
    """The values of :data:`PARAM_DIMS` of a job: jobs with equal keys fill the same cells
    of a study dataset (and must therefore differ in their seeds only)."""
    return (model, rnd(p.gamma), rnd(p.hurst), p.eps_t, rnd(p.eps_f))


def param_coords(p: SurfaceParams, model: str) -> dict:
    """Length-1 parameter coordinates shared by every per-job dataset."""
    values = dict(zip(PARAM_DIMS, param_key(p, model), strict=True))
    attrs = {
        "model": {"long_name": "contact model"},
        "gamma": {"units": DIMENSIONLESS, "long_name": "Peklenik number (> 1: stretched along x)"},
        "hurst": {"units": DIMENSIONLESS, "long_name": "Hurst exponent H"},
        "eps_t": {"units": DIMENSIONLESS,
                  "long_name": "eps_t = max(sqrt(gamma), 1/sqrt(gamma)) lambda_r / L"},
        "eps_f": {"units": DIMENSIONLESS, "long_name": "eps_f = lambda_s / lambda_r"},
    }
    return {dim: (dim, [values[dim]], attrs[dim]) for dim in PARAM_DIMS}


def expand(values: ArrayLike, extra_dims: tuple[str, ...]) -> tuple[tuple[str, ...], np.ndarray]:
    """Array over ``extra_dims`` -> (PARAM_DIMS + extra_dims, array with length-1 axes)."""
    a = np.asarray(values)
    return PARAM_DIMS + extra_dims, a.reshape((1,) * len(PARAM_DIMS) + a.shape)


def var(values: ArrayLike, extra_dims: tuple[str, ...], units: str, long_name: str,
        **attrs) -> xr.Variable:
    """A job variable over PARAM_DIMS + ``extra_dims``; integers get the fill value -1."""
    dims, a = expand(values, extra_dims)
    v = xr.Variable(dims, a, {"units": units, "long_name": long_name, **attrs})
    if a.dtype == bool:
        v.attrs = {**flags(), **v.attrs}
    if np.issubdtype(a.dtype, np.integer) or a.dtype == bool:
        v = xr.Variable(dims, a.astype(np.int32), v.attrs)
        v.encoding = {"_FillValue": np.int32(INT_FILL), "dtype": "int32"}
    return v


def seed_coord(seeds: ArrayLike) -> tuple:
    """The ``seed`` coordinate of a job's dataset."""
    return ("seed", np.asarray(seeds, dtype=np.int64),
            {"units": DIMENSIONLESS, "long_name": "surface seed"})


def surface_vars(p: SurfaceParams, seed: int) -> dict:
    """Grid and size of the job's surfaces (parameters that are not dimensions)."""
    spec = p.spec(seed)
    return {
        "l_over_lambda_r": var(rnd(p.size), (), DIMENSIONLESS,
                               "L / lambda_r (L: side of the unit cell)"),
        "nx": var(np.int32(spec.nx), (), DIMENSIONLESS, "grid points along x"),
        "ny": var(np.int32(spec.ny), (), DIMENSIONLESS, "grid points along y"),
        "points_per_lambda_s": var(float(p.points_per_lambda_s), (), DIMENSIONLESS,
                                   "grid points per shortest wavelength (requested; the grid "
                                   "has nx lambda_s sqrt(gamma) / lx along x, ny lambda_s / "
                                   "(sqrt(gamma) ly) along y)"),
        # the geometry itself, not only the request it was made from: a researcher needs the
        # spacing (the cell is 1 x 1 at every gamma, its pixels then not square)
        "lx": var(float(spec.lx), (), LENGTH_UNITS, "cell length along x"),
        "ly": var(float(spec.ly), (), LENGTH_UNITS, "cell length along y"),
        "lambda_r": var(float(spec.lambda_r), (), LENGTH_UNITS,
                        "roll-off wavelength of the isotropic spectrum (Eq. 1-2; the surface's "
                        "is sqrt(gamma) times it along x, 1 / sqrt(gamma) along y)"),
        "lambda_s": var(float(spec.lambda_s), (), LENGTH_UNITS,
                        "short cut-off wavelength of the isotropic spectrum (as lambda_r)"),
    }


def no_fill_on_coords(ds: xr.Dataset) -> xr.Dataset:
    """Float coordinates get no NaN _FillValue when written."""
    for name in ds.coords:
        if ds[name].dtype.kind == "f":
            ds[name].encoding["_FillValue"] = None
    return ds


def threshold_values(ds: xr.Dataset) -> xr.DataArray:
    """The a_c* to analyse: perimeter-corrected (first-order grid bias of the elastic
    contact area removed, docs/accuracy.md) where the grid has at least
    :data:`CORRECTION_MIN_POINTS` points per lambda_s, the range the constant is calibrated
    on; the raw ``a_c_star`` elsewhere (at 2 points per lambda_s the correction over-shoots:
    isotropic a_c* 0.385 corrected vs 0.436 raw vs about 0.41 converged)."""
    raw = ds["a_c_star"]
    take = corrected_taken(ds)
    if take is None:
        return raw
    return xr.where(take, ds["a_c_star_corrected"], raw).transpose(*raw.dims)


def corrected_taken(ds: xr.Dataset) -> xr.DataArray | None:
    """Where :func:`threshold_values` takes ``a_c_star_corrected`` (a grid of at least
    :data:`CORRECTION_MIN_POINTS` points per lambda_s and a corrected value), over
    ``a_c_star``'s dimensions; None where the dataset cannot tell (raw throughout)."""
    if "a_c_star_corrected" not in ds or "points_per_lambda_s" not in ds:
        return None
    take = (fine_grid(ds) & ds["a_c_star_corrected"].notnull()).broadcast_like(ds["a_c_star"])
    return take.transpose(*ds["a_c_star"].dims)


def fine_grid(ds: xr.Dataset) -> xr.DataArray:
    """Where the grid has at least :data:`CORRECTION_MIN_POINTS` points per lambda_s, over
    ``a_c_star``'s dimensions: the range the perimeter correction is calibrated on."""
    fine = ds["points_per_lambda_s"] >= CORRECTION_MIN_POINTS
    return fine.broadcast_like(ds["a_c_star"]).transpose(*ds["a_c_star"].dims)


def single_setting(a: xr.DataArray,
                   dims: tuple[str, ...] = STUDY_ONE_VALUE["threshold_vs_size"],
                   ) -> xr.DataArray:
    """``a`` at its single value of each of ``dims`` (those it has); InputError naming the
    values where it has several: a finite-size fit or a figure of one series mixes no
    settings."""
    for dim in dims:
        if dim in a.dims:
            if a.sizes[dim] != 1:
                raise InputError(f"this analysis needs one {dim}, the dataset has "
                                 f"{a.sizes[dim]}: {', '.join(map(str, a[dim].values))}")
            a = a.isel({dim: 0})
    return a


def area_values(ds: xr.Dataset) -> xr.DataArray:
    """The contact area to plot sigma against: the perimeter-corrected ``a_c`` where the
    ladder stored one (elastic; the fixed-load correction is calibrated from 2 points per
    lambda_s up, error +0.004 at 2 points, docs/accuracy.md), the raw ``a_c`` elsewhere."""
    raw = ds["area_fraction"]
    if "area_fraction_corrected" not in ds:
        return raw
    corrected = ds["area_fraction_corrected"]
    return xr.where(corrected.notnull(), corrected, raw).transpose(*raw.dims)


def unbracketed_searches(ds: xr.Dataset) -> tuple[int, int]:
    """(searches that did not bracket a_c*, searches run) of a threshold dataset, a search
    being one seed and axis: an unbracketed one has a NaN a_c*, which the seed means and
    fits leave out, so they stand on the seeds that remain. (0, 0) without ``bracketed``."""
    if "bracketed" not in ds:
        return 0, 0
    flag = ds["bracketed"]
    return int((flag == 0).sum()), int(flag.notnull().sum())
