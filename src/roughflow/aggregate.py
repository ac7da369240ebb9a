"""Combine per-job datasets of a study into one dataset (outer join on the coordinates).

Jobs that did not run leave NaN (never zero); variables that are integers in the job
files are written back as int32 with the explicit fill value -1; float coordinates get
no ``_FillValue``. Attributes that differ between jobs are dropped; the job ids are kept
in the ``jobs`` attribute.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Sequence

import numpy as np
import xarray as xr

from roughflow.errors import InputError
from roughflow.io import write_dataset

log = logging.getLogger(__name__)
INT_FILL = -1


def load(path: str | os.PathLike) -> xr.Dataset:
    if not os.path.exists(path):
        raise InputError(f"dataset {str(path)!r} does not exist")
    with xr.open_dataset(path) as ds:
        return ds.load()


def combine(datasets: Sequence[xr.Dataset]) -> xr.Dataset:
    """Outer combination by coordinates (``xr.combine_by_coords``, falling back to merge)."""
    if not datasets:
        raise InputError("nothing to aggregate: no datasets given")
    # integer variables arrive as int (no missing values) or, decoded with a fill value,
    # as float with an integer on-disk dtype in their encoding
    int_vars = {name for ds in datasets for name, v in ds.data_vars.items()
                if v.dtype.kind in "iu" or np.dtype(v.encoding.get("dtype", "f8")).kind in "iu"}
    if len(datasets) == 1:
        out = datasets[0].copy()
    else:
        try:
            out = xr.combine_by_coords(list(datasets), join="outer",
                                       combine_attrs="drop_conflicts", data_vars="all")
        except ValueError as exc:
            log.info("combine_by_coords failed (%s); merging instead", exc)
            out = xr.merge(list(datasets), join="outer", compat="no_conflicts",
                           combine_attrs="drop_conflicts")
    ids = [str(ds.attrs.get("job_id", "")) for ds in datasets]
    out.attrs["jobs"] = " ".join(i for i in ids if i)
    out.attrs["n_jobs"] = len(datasets)
    for name in out.variables:
        out[name].encoding = {}
    for name in int_vars & set(out.data_vars):
        out[name].encoding = {"dtype": "int32", "_FillValue": np.int32(INT_FILL)}
    for name in out.coords:
        if out[name].dtype.kind == "f":
            out[name].encoding["_FillValue"] = None
    return out


def aggregate(paths: Sequence[str | os.PathLike], output: str | os.PathLike,
              *, study: str | None = None) -> xr.Dataset:
    """Load, combine and atomically write the study dataset; returns it."""
    datasets = [load(p) for p in paths]
    out = combine(datasets)
    if study is not None:
        out.attrs["study"] = study
    out.attrs["title"] = f"roughflow study {study or ''}".strip()
    write_dataset(out, output)
    log.info("aggregated %d datasets into %s (%s)", len(datasets), output,
             dict(out.sizes))
    return out
