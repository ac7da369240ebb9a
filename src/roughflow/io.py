"""netCDF files: reading and writing any dataset, and the surface file format.

Every variable carries ``units`` and ``long_name``; parameters are attributes
or coordinates. Files are written to a temporary name in the same folder and
renamed into place, so an interrupted job never leaves a file that looks valid, and every
file gets its provenance attributes (:mod:`roughflow.provenance`).
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
from roughflow.errors import InputError, require_field, require_positive
from roughflow.provenance import PROVENANCE_ATTRS, Provenance
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


#: First bytes of netCDF files: classic, 64-bit offset, CDF-5, and netCDF-4 (HDF5).
NETCDF_MAGIC = (b"CDF\x01", b"CDF\x02", b"CDF\x05", b"\x89HDF\r\n\x1a\n")


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def publish(tmp: str | os.PathLike, path: str | os.PathLike) -> None:
    """Give the finished temporary file ``tmp`` the permissions of a newly created file
    (0666 less the umask; ``mkstemp`` makes it 0600, unreadable to a group that shares the
    results) and rename it to ``path`` (atomic on one file system)."""
    os.chmod(tmp, 0o666 & ~_umask())
    os.replace(tmp, path)


def write_dataset(ds: xr.Dataset, path: str | os.PathLike, *,
                  provenance: Provenance | None = None) -> Path:
    """Write ``ds`` to ``path`` atomically (temporary file + rename), with the permissions
    of a newly created file and the attributes of ``provenance`` (default: the Python
    API's, :class:`~roughflow.provenance.Provenance`) in place of any it carried."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    ds = ds.copy()
    attrs = {k: v for k, v in ds.attrs.items() if k not in PROVENANCE_ATTRS}
    attrs.update((provenance or Provenance()).attrs())
    ds.attrs = clean_attrs(attrs)
    for name in ds.variables:
        ds[name].attrs = clean_attrs(ds[name].attrs)
    fd, tmp = tempfile.mkstemp(suffix=".nc.part", dir=path.parent)
    os.close(fd)
    try:
        ds.to_netcdf(tmp)
        publish(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    return path


def read_dataset(path: str | os.PathLike, kinds: str | tuple[str, ...] | None = None, *,
                 what: str = "input") -> xr.Dataset:
    """Load the netCDF file ``path`` into memory, checking that it is one of ``kinds``
    (:mod:`roughflow.datasets.kinds`); any unreadable file (missing, a directory, empty,
    not netCDF, truncated) or a dataset of another kind raises :class:`InputError` naming
    the file. ``what`` names the role of the file in messages."""
    from roughflow.datasets.kinds import check_kind

    path = Path(path)
    source = f"{what} {str(path)!r}"
    if not path.exists():
        raise InputError(f"{source} does not exist")
    if path.is_dir():
        raise InputError(f"{source} is a directory, not a netCDF file")
    if path.stat().st_size == 0:
        raise InputError(f"{source} is empty (0 bytes)")
    with open(path, "rb") as fh:
        head = fh.read(8)
    if not head.startswith(NETCDF_MAGIC):
        hint = ("; a measured scan is read with `roughflow import`"
                if "surface" in ((kinds,) if isinstance(kinds, str) else kinds or ()) else "")
        raise InputError(f"{source} is not a netCDF file (it starts with {head!r}){hint}")
    try:
        with xr.open_dataset(path) as ds:
            ds.load()
    except MemoryError:
        raise
    except Exception as exc:  # netCDF4/HDF5/xarray raise OSError, ValueError, RuntimeError...
        reason = (str(exc).splitlines() or [""])[0][:160]
        raise InputError(f"cannot read {source} as netCDF ({type(exc).__name__}: {reason}); is "
                         "it a complete file written by roughflow?") from None
    if kinds is not None:
        check_kind(ds, kinds, source)
    return ds


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
    from roughflow.datasets.kinds import check_kind

    check_kind(ds, "surface", "the dataset")
    heights = require_field("heights", ds["heights"].transpose("x", "y").values)
    lx, ly = require_positive("lx", ds.attrs["lx"]), require_positive("ly", ds.attrs["ly"])
    spec = None
    if "spec_nx" in ds.attrs:
        kw = {k[5:]: ds.attrs[k] for k in ds.attrs if k.startswith("spec_")}
        try:
            for k in ("nx", "ny", "seed"):
                kw[k] = int(kw[k])
            for k in ("lx", "ly", "hurst", "gamma", "lambda_r", "lambda_s", "rms_slope"):
                kw[k] = float(kw[k])
            spec = SurfaceSpec(**kw)
        except (KeyError, TypeError, ValueError) as exc:
            raise InputError(f"the spec_* attributes of the surface are incomplete or invalid "
                             f"({type(exc).__name__}: {exc})") from None
        if (spec.nx, spec.ny) != heights.shape:
            raise InputError(f"heights have shape {heights.shape} but the spec_* attributes "
                             f"say {spec.nx} x {spec.ny}")
    scan = None
    if "scan_source" in ds.attrs:
        try:
            kw = {f.name: ds.attrs[f"scan_{f.name}"] for f in fields(ScanInfo)}
            for k in ("length_scale", "rms_gradient"):
                kw[k] = float(kw[k])
            kw["filled"] = int(kw["filled"])
            kw["periodic"] = bool(int(kw["periodic"]))
        except (KeyError, TypeError, ValueError) as exc:
            raise InputError(f"the scan_* attributes of the surface are incomplete or invalid "
                             f"({type(exc).__name__}: {exc})") from None
        scan = ScanInfo(**{k: v if not isinstance(v, np.str_) else str(v) for k, v in kw.items()})
    return Surface(heights=heights, lx=lx, ly=ly, spec=spec, scan=scan)


def read_surface(path: str | os.PathLike) -> Surface:
    """Read a surface file written by ``roughflow surface`` or ``roughflow import``."""
    return surface_from_dataset(read_dataset(path, "surface", what="surface file"))
