"""netCDF files: reading and writing any dataset, and the surface file format.

Every variable carries ``units`` and ``long_name``; parameters are attributes
or coordinates. Files are written to a temporary name in the same folder and
renamed into place, so an interrupted job never leaves a file that looks valid, and every
file gets its provenance attributes (:mod:`roughflow.provenance`).
"""

from __future__ import annotations

import contextlib
import errno
import math
import os
import shutil
import tempfile
from collections.abc import Callable, Sequence
from dataclasses import MISSING, fields
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import xarray as xr

from roughflow.datasets.results import spec_attrs
from roughflow.datasets.units import LENGTH_UNITS, grid_coords
from roughflow.errors import InputError, OutputError, require_field, require_positive
from roughflow.files import (
    denied,
    part_prefix,
    publish,
    raise_if_stopping,
    remove_stale_parts,
    require_readable,
    signals_held,
    sticky_owner,
    user_name,
)
from roughflow.provenance import PROVENANCE_ATTRS, Provenance
from roughflow.surface import ScanInfo, Surface, SurfaceSpec

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["NETCDF_MAGIC", "DAMAGED_OUTPUT_ADVICE", "check_output", "Writer", "figure_writer",
           "text_writer", "save_figure",
           "write_together", "dataset_methods", "default_provenance", "dataset_writer",
           "write_dataset", "read_dataset", "surface_to_dataset", "surface_from_dataset",
           "read_surface"]


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


def check_output(path: str | os.PathLike, *, option: str = "--output",
                 suffixes: tuple[str, ...] = (".nc",)) -> None:
    """Refuse an output path that cannot be written, before any work: a wrong suffix, an
    existing directory, a parent that is a file, a folder where no file can be created
    (probed by creating and removing a temporary file, which also works for root), or a
    file that this user may not replace (:func:`_check_replaceable`)."""
    path = str(path)
    if not path.strip():
        raise InputError(f"{option} is empty; give a file name")
    p = Path(path)
    try:
        if p.is_dir():
            raise InputError(f"{option} {path!r} is a directory; give a file name")
        if suffixes and p.suffix.lower() not in suffixes:
            raise InputError(f"{option} {path!r}: the file name must end in "
                             f"{' or '.join(suffixes)}")
        parent = p.absolute().parent
        while not parent.exists():
            parent = parent.parent
        if not parent.is_dir():
            raise InputError(f"{option} {path!r}: {str(parent)!r} is a file, not a directory")
    except PermissionError as exc:  # a folder on the way that this user may not enter
        raise InputError(f"{option} {path!r} cannot be written: {denied(exc)}") from None
    try:
        fd, tmp = tempfile.mkstemp(prefix=".roughflow-probe-", dir=parent)
    except OSError as exc:
        raise InputError(f"{option} {path!r}: cannot create files in {str(parent)!r} "
                         f"({exc.strerror})") from None
    os.close(fd)
    os.unlink(tmp)
    _check_replaceable(p, option)


def _check_replaceable(path: Path, option: str) -> None:
    """Refuse an existing ``path`` that the rename publishing the new one would be refused
    (:func:`roughflow.files.sticky_owner`): the refusal came after the work, whatever the
    command had computed."""
    owner = sticky_owner(path.absolute())
    if owner is not None:
        raise InputError(f"{option} {str(path)!r} belongs to {user_name(owner)}, in "
                         f"{str(path.absolute().parent)!r}, a folder with the sticky bit: "
                         "only its owner may replace it; give another name")


Writer = tuple[Path, Callable[[str], object]]


def figure_writer(fig: Figure, path: str | os.PathLike, **savefig_kw) -> Writer:
    """``(path, write)`` for :func:`write_together`: renders the matplotlib ``fig`` in the
    format of ``path``'s suffix."""
    path = Path(path)
    return path, lambda tmp: fig.savefig(tmp, format=path.suffix.lstrip(".").lower(),
                                         **savefig_kw)


def text_writer(text: str, path: str | os.PathLike) -> Writer:
    """``(path, write)`` for :func:`write_together`: ``text`` as UTF-8."""
    return Path(path), lambda tmp: Path(tmp).write_text(text, encoding="utf-8")


def save_figure(fig: Figure, *paths: str | os.PathLike, **savefig_kw) -> Path:
    """Render the matplotlib ``fig`` to each of ``paths`` (the format from each suffix),
    published together (:func:`write_together`), creating missing folders; a failed render
    leaves none of them. Returns the first path."""
    return write_together([figure_writer(fig, p, **savefig_kw) for p in paths])[0]


#: Free bytes below which a failed write is taken for a full disk: netCDF and matplotlib
#: report it as "NetCDF: HDF error" or an AttributeError, not as ENOSPC.
_NEARLY_FULL = 1 << 20
_NO_SPACE = {errno.ENOSPC, getattr(errno, "EDQUOT", errno.ENOSPC)}


def _write_failure(path: Path, exc: BaseException) -> OutputError | None:
    """An :class:`OutputError` naming ``path`` where ``exc`` came from the file system (no
    space, a folder that became unwritable), else None (an error of the writer itself)."""
    try:
        free = shutil.disk_usage(path.parent).free
    except OSError:
        free = None
    if getattr(exc, "errno", None) in _NO_SPACE or (free is not None and free < _NEARLY_FULL):
        shown = "" if free is None else f", {free} bytes free"
        return OutputError(f"cannot write {str(path)!r}: no space left on its disk or quota "
                           f"({type(exc).__name__}: {exc}{shown})")
    if isinstance(exc, OSError):
        return OutputError(f"cannot write {str(path)!r}: {exc}")
    return None


def write_together(writers: Sequence[Writer]) -> list[Path]:
    """Call each ``write(tmp)`` on a temporary file next to its path (missing folders
    created), and only when all have succeeded :func:`publish` them all, so that a command's
    outputs (a figure's PNG and PDF, a flow file and its plot) appear together or not at
    all. A failure leaves none of the temporary files; one of the file system (disk full)
    raises :class:`~roughflow.errors.OutputError` naming the file."""
    tmps: list[str] = []
    published: list[Path] = []
    path = None
    try:
        # a SIGTERM or Ctrl-C waits until the files are written (the writers hold locks that
        # an exception raised inside them would leave held: files.signals_held); one that
        # arrived meanwhile, or whose exception Python dropped in a destructor, publishes
        # nothing
        with signals_held():
            for path, write in writers:
                path.parent.mkdir(parents=True, exist_ok=True)
                remove_stale_parts(path)
                fd, tmp = tempfile.mkstemp(prefix=part_prefix(path), suffix=".part",
                                           dir=path.parent)
                os.close(fd)
                tmps.append(tmp)
                write(tmp)
                raise_if_stopping()
            for tmp, (path, _) in zip(tmps, writers, strict=True):
                publish(tmp, path)
                published.append(path)
    except BaseException as exc:
        if published and len(published) < len(writers):
            # a rename failed after others succeeded: take those back, so that no
            # half-set of outputs is left (their previous versions are gone already)
            for done in published:
                with contextlib.suppress(OSError):
                    os.unlink(done)
        # judged before the temporary files go: they are what filled the disk
        failure = (_write_failure(path, exc) if path is not None and isinstance(exc, Exception)
                   else None)
        for tmp in tmps:
            if os.path.exists(tmp):
                os.unlink(tmp)
        if failure is not None:
            raise failure from exc
        raise
    return [p for p, _ in writers]


def dataset_methods(ds: xr.Dataset) -> tuple[str, ...]:
    """The methods (:data:`roughflow.citation.METHODS`) behind a dataset of
    :mod:`roughflow.datasets`, read from its title and model attributes; () where unknown.
    The command line names its methods itself; this gives a file written from Python the
    same ``references``."""
    from roughflow.citation import LEAK_METHODS, contact_methods, threshold_methods
    from roughflow.defaults import MODELS

    a = ds.attrs
    title = str(a.get("title", ""))
    if title == "roughflow surface":
        return ("surface",)
    if title == "roughflow flow":
        return ("reynolds",)
    if title == "roughflow leak":
        return LEAK_METHODS
    model = str(a.get("model", ""))
    if model not in MODELS:
        return ()
    solve = (model, str(a["method"]) if a.get("method") else None, a.get("adhesion_repulsion"))
    # a generated surface (its spec_* attributes) is cited as the command's input file is
    generated = ("surface",) if any(k.startswith("spec_") for k in a) else ()
    if title == "roughflow contact":
        return (*generated, *contact_methods(*solve))
    if title == "roughflow percolation threshold":
        return (*generated, *threshold_methods(*solve))
    return ()


def default_provenance(ds: xr.Dataset) -> Provenance:
    """The Python API's provenance of ``ds``, citing the methods of :func:`dataset_methods`."""
    return Provenance().using(*dataset_methods(ds))


def dataset_writer(ds: xr.Dataset, path: str | os.PathLike, *,
                   provenance: Provenance | None = None) -> Writer:
    """``(path, write)`` for :func:`write_together`: ``ds`` with the attributes of
    ``provenance`` in place of any it carried, attributes netCDF can store, written as
    netCDF. The default provenance is the Python API's
    (:class:`~roughflow.provenance.Provenance`), citing the methods of
    :func:`dataset_methods`."""
    ds = ds.copy()
    attrs = {k: v for k, v in ds.attrs.items() if k not in PROVENANCE_ATTRS}
    if provenance is None:
        provenance = default_provenance(ds)
    attrs.update(provenance.attrs())
    ds.attrs = clean_attrs(attrs)
    for name in ds.variables:
        ds[name].attrs = clean_attrs(ds[name].attrs)
    return Path(path), ds.to_netcdf


def write_dataset(ds: xr.Dataset, path: str | os.PathLike, *,
                  provenance: Provenance | None = None) -> Path:
    """Write ``ds`` to ``path`` atomically (temporary file + rename), with the permissions
    of a newly created file and the attributes of ``provenance`` (default: the Python
    API's, :class:`~roughflow.provenance.Provenance`) in place of any it carried."""
    return write_together([dataset_writer(ds, path, provenance=provenance)])[0]


#: What to do with a workflow file that cannot be read (roughflow's own writes are atomic:
#: damage from outside, a full disk on another writer's side, a copy cut short).
DAMAGED_OUTPUT_ADVICE = ("(A damaged output of a workflow step: delete it, and snakemake makes "
                         "it again.)")


def read_dataset(path: str | os.PathLike, kinds: str | tuple[str, ...] | None = None, *,
                 what: str = "input") -> xr.Dataset:
    """Load the netCDF file ``path`` into memory, checking that it is one of ``kinds``
    (:mod:`roughflow.datasets.kinds`); any unreadable file (missing, a directory, empty,
    not netCDF, truncated) or a dataset of another kind raises :class:`InputError` naming
    the file. ``what`` names the role of the file in messages."""
    from roughflow.datasets.kinds import check_kind

    path = Path(path)
    source = f"{what} {str(path)!r}"
    require_readable(path, source)
    if path.stat().st_size == 0:
        raise InputError(f"{source} is empty (0 bytes)")
    with open(path, "rb") as fh:
        head = fh.read(8)
    if not head.startswith(NETCDF_MAGIC):
        hint = ("; a measured scan is read with `roughflow import`"
                if "surface" in ((kinds,) if isinstance(kinds, str) else kinds or ()) else "")
        raise InputError(f"{source} is not a netCDF file (it starts with {head!r}){hint}")
    try:
        with signals_held(), xr.open_dataset(path) as ds:  # as the writes (files.signals_held)
            ds.load()
    except MemoryError:
        raise
    except Exception as exc:  # netCDF4/HDF5/xarray raise OSError, ValueError, RuntimeError...
        reason = (str(exc).splitlines() or [""])[0][:160]
        raise InputError(f"cannot read {source} as netCDF ({type(exc).__name__}: {reason}); is "
                         f"it a complete file written by roughflow? {DAMAGED_OUTPUT_ADVICE}"
                         ) from None
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
    # name the file in messages where the dataset was read from one
    where = f"{ds.encoding['source']!r}: " if "source" in ds.encoding else ""
    heights = require_field(f"{where}heights", ds["heights"].transpose("x", "y").values)
    try:
        lx, ly = (float(ds.attrs[k]) for k in ("lx", "ly"))
    except (TypeError, ValueError):
        raise InputError(f"{where}the attributes lx, ly must be numbers, got "
                         f"{ds.attrs['lx']!r}, {ds.attrs['ly']!r}") from None
    lx, ly = require_positive(f"{where}lx", lx), require_positive(f"{where}ly", ly)
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
            raise InputError(f"{where}heights have shape {heights.shape} but the spec_* "
                             f"attributes say {spec.nx} x {spec.ny}")
        if not (math.isclose(spec.lx, lx, rel_tol=1e-12)
                and math.isclose(spec.ly, ly, rel_tol=1e-12)):
            raise InputError(f"{where}the cell is {lx!r} x {ly!r} but the spec_* attributes "
                             f"say {spec.lx!r} x {spec.ly!r}")
    scan = None
    if "scan_source" in ds.attrs:
        try:
            # a field with a default may be missing (files written before it existed)
            kw = {f.name: ds.attrs[f"scan_{f.name}"] if f.default is MISSING else
                  ds.attrs.get(f"scan_{f.name}", f.default) for f in fields(ScanInfo)}
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
    """Read a surface file written by ``roughflow surface`` or ``roughflow import`` (or
    :func:`write_dataset` of :func:`surface_to_dataset`) back as a
    :class:`~roughflow.surface.Surface`: its cell ``lx`` x ``ly`` as written (not the
    square pixels that :meth:`Surface.from_array` assumes without ``ly``), its
    :class:`~roughflow.surface.SurfaceSpec` where it was generated and, for an imported
    scan, its physical scale (``surface.scan``). Raises
    :class:`~roughflow.errors.InputError` for a file of another kind.

    >>> from roughflow.io import read_surface
    >>> surface = read_surface("s.nc")        # doctest: +SKIP
    """
    return surface_from_dataset(read_dataset(path, "surface", what="surface file"))
