"""netCDF files: writing any dataset atomically, and the surface file format.

Every variable carries ``units`` and ``long_name``; parameters are attributes
or coordinates. Files are written to a temporary name in the same folder and
renamed into place, so an interrupted job never leaves a file that looks valid.
"""

from __future__ import annotations

import os
import tempfile
from dataclasses import fields
from pathlib import Path

import numpy as np
import xarray as xr

from roughflow.datasets.results import spec_attrs
from roughflow.datasets.units import LENGTH_UNITS, grid_coords
from roughflow.errors import InputError
from roughflow.surface import ScanInfo, Surface, SurfaceSpec


def _attr_value(v):
    """netCDF attributes cannot hold None or bool: store them as strings/ints."""
    if v is None:
        return "none"
    if isinstance(v, (bool, np.bool_)):
        return int(v)
    return v


def clean_attrs(attrs: dict) -> dict:
    return {k: _attr_value(v) for k, v in attrs.items()}


def write_dataset(ds: xr.Dataset, path: str | os.PathLike) -> Path:
    """Write ``ds`` to ``path`` atomically (temporary file + rename)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    ds = ds.copy()
    ds.attrs = clean_attrs(ds.attrs)
    for name in ds.variables:
        ds[name].attrs = clean_attrs(ds[name].attrs)
    fd, tmp = tempfile.mkstemp(suffix=".nc.part", dir=path.parent)
    os.close(fd)
    try:
        ds.to_netcdf(tmp)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    return path


def surface_to_dataset(surface: Surface) -> xr.Dataset:
    """Dataset with ``heights(x, y)`` and every spec parameter as an attribute."""
    nx, ny = surface.shape
    ds = xr.Dataset(
        {
            "heights": (
                ("x", "y"),
                surface.heights,
                {"units": LENGTH_UNITS, "long_name": "height of the rigid rough surface"},
            )
        },
        coords=grid_coords(nx, ny, surface.lx, surface.ly),
        attrs={"lx": surface.lx, "ly": surface.ly, "title": "roughflow surface"},
    )
    ds.attrs.update(spec_attrs(surface))
    return ds


def surface_from_dataset(ds: xr.Dataset) -> Surface:
    """Inverse of :func:`surface_to_dataset` (the spec is restored when present)."""
    if "heights" not in ds:
        raise InputError("dataset has no 'heights' variable: not a roughflow surface file")
    heights = np.asarray(ds["heights"].transpose("x", "y").values, dtype=np.float64)
    spec = None
    if "spec_nx" in ds.attrs:
        kw = {k[5:]: ds.attrs[k] for k in ds.attrs if k.startswith("spec_")}
        for k in ("nx", "ny", "seed"):
            kw[k] = int(kw[k])
        for k in ("lx", "ly", "hurst", "gamma", "lambda_r", "lambda_s", "rms_slope"):
            kw[k] = float(kw[k])
        spec = SurfaceSpec(**kw)
    scan = None
    if "scan_source" in ds.attrs:
        kw = {f.name: ds.attrs[f"scan_{f.name}"] for f in fields(ScanInfo)}
        for k in ("length_scale", "rms_gradient"):
            kw[k] = float(kw[k])
        kw["filled"] = int(kw["filled"])
        kw["periodic"] = bool(int(kw["periodic"]))
        scan = ScanInfo(**{k: v if not isinstance(v, np.str_) else str(v) for k, v in kw.items()})
    return Surface(heights=heights, lx=float(ds.attrs["lx"]), ly=float(ds.attrs["ly"]), spec=spec,
                   scan=scan)


def read_surface(path: str | os.PathLike) -> Surface:
    """Read a surface file written by ``roughflow surface`` or ``roughflow import``."""
    path = Path(path)
    if not path.exists():
        raise InputError(f"surface file {str(path)!r} does not exist")
    try:
        with xr.open_dataset(path) as ds:
            ds.load()
    except (OSError, ValueError) as exc:
        raise InputError(f"cannot read {str(path)!r} as a netCDF surface file ({exc}); a "
                         "measured scan is read with `roughflow import`") from None
    return surface_from_dataset(ds)
