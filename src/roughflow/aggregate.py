"""Combine per-job datasets of a study into one dataset (outer join on the coordinates).

Jobs that did not run leave NaN (never zero); variables that are integers in the job
files are written back as int32 with the explicit fill value -1; float coordinates get
no ``_FillValue``. Attributes that differ between jobs, or that some jobs lack, are
dropped (what differs between jobs is written as variables: the ladder's adhesion and
theory a_c*); the job ids are kept in the ``jobs`` attribute.

Leak files (``roughflow leak``, the measured study) are concatenated along ``scan`` with an
outer join on ``pressure`` (scans may have different pressure grids: NaN where a scan has
no value), so per-scan variables keep their dimensions (``scan``[, ``axis``]); what
describes each scan (boundary treatment, the question, the scan's provenance) is kept as
variables over ``scan`` (:func:`roughflow.datasets.leak.with_scan_variables`).

Only job files of one scene (threshold or ladder) combine, and no two of them may fill the
same cells: jobs with the same parameters (model, gamma, hurst, eps_t, eps_f) must have
distinct seeds and equal settings (:func:`check_disjoint`). Anything else would silently
drop or duplicate data, so it is refused (the workflow refuses such configs at planning,
``roughflow.scenes.expand.check_collisions``).
"""

from __future__ import annotations

import logging
import os
from collections.abc import Sequence
from dataclasses import replace

import numpy as np
import xarray as xr

from roughflow.datasets.kinds import check_kind
from roughflow.datasets.leak import with_scan_variables
from roughflow.datasets.results import ADHESION_FIELDS, ADHESION_REPULSION_FIELD
from roughflow.datasets.sweep import INT_FILL, PARAM_DIMS, unbracketed_searches
from roughflow.defaults import JOB_KINDS
from roughflow.errors import InputError
from roughflow.io import default_provenance, read_dataset, write_dataset
from roughflow.provenance import Provenance, settings_of_inputs

__all__ = ["load", "ADDED_JOB_VARIABLES", "check_disjoint", "combine", "aggregate"]

log = logging.getLogger(__name__)


def load(path: str | os.PathLike, kinds: str | tuple[str, ...] | None = None) -> xr.Dataset:
    """Read a dataset (:func:`roughflow.io.read_dataset`), optionally of given kinds."""
    return read_dataset(path, kinds, what="dataset")


#: Variables that job files of older roughflow versions lack (the cell's geometry; the
#: ladder's theory a_c* and adhesion, which they kept as attributes): their absence is no
#: conflict between seed groups of one setting.
ADDED_JOB_VARIABLES = frozenset({"lx", "ly", "lambda_r", "lambda_s", "a_c_star_theory",
                                 "a_c_star_alt", *ADHESION_FIELDS, ADHESION_REPULSION_FIELD[0]})


def _key(ds: xr.Dataset, source: str) -> tuple:
    """The job's parameter values (one per :data:`PARAM_DIMS`)."""
    sizes = {d: ds.sizes[d] for d in PARAM_DIMS}
    if any(n != 1 for n in sizes.values()):
        raise InputError(f"{source} covers several parameter values {sizes}: aggregate combines "
                         "job files (roughflow scene), not study datasets")
    return tuple(ds[d].values[0].item() for d in PARAM_DIMS)


def _settings(ds: xr.Dataset) -> dict:
    """What jobs stacked along ``seed`` must share: every variable without a seed
    dimension (grid, resolution, ...) and the job's settings attribute."""
    out = {name: np.unique(v.values).tolist() for name, v in ds.data_vars.items()
           if "seed" not in v.dims}
    if "job_settings" in ds.attrs:
        out["job_settings"] = str(ds.attrs["job_settings"])
    return out


def check_disjoint(datasets: Sequence[xr.Dataset], sources: Sequence[str]) -> None:
    """Refuse job datasets that would fill the same cells of the study dataset: the same
    parameters and a common seed (the combination would duplicate or drop the seed), or the
    same parameters and different settings (the study would mix two computations, and
    variables such as ``points_per_lambda_s`` would collide)."""
    seen: dict[tuple, list[int]] = {}
    for i, (ds, src) in enumerate(zip(datasets, sources, strict=True)):
        key = _key(ds, src)
        seeds = set(ds["seed"].values.tolist())
        if len(seeds) != ds.sizes["seed"]:
            raise InputError(f"{src} lists a seed twice: {ds['seed'].values.tolist()}")
        for j in seen.get(key, []):
            other = datasets[j]
            common = sorted(seeds & set(other["seed"].values.tolist()))
            params = ", ".join(f"{d}={v}" for d, v in zip(PARAM_DIMS, key, strict=True))
            if common:
                raise InputError(f"{sources[j]} and {src} both hold seeds {common} of {params}: "
                                 "combining them would drop or duplicate data")
            a, b = _settings(other), _settings(ds)
            # variables (points_per_lambda_s, nx, ...) say it plainest, job_settings last;
            # one that a job written before it existed lacks is no conflict (its settings,
            # in job_settings, are still compared; the warning on mixed commits names it)
            keys = (set(a) | set(b)) - ((set(a) ^ set(b)) & ADDED_JOB_VARIABLES)
            diff = sorted((k for k in keys if k not in a or k not in b or not _same(a[k], b[k])),
                          key=lambda k: (k == "job_settings", k))
            if diff:
                what = "; ".join(f"{k} {a.get(k, '(none)')} vs {b.get(k, '(none)')}"
                                 for k in diff[:3])
                raise InputError(
                    f"{sources[j]} and {src} hold the same parameters ({params}) with "
                    f"different settings ({what}); the study dataset has no dimension for "
                    "them: aggregate them separately")
        seen.setdefault(key, []).append(i)


def _check_scans_disjoint(datasets: Sequence[xr.Dataset], sources: Sequence[str]) -> None:
    """Leak files are stacked along ``scan``: each scan name may appear once."""
    seen: dict[str, str] = {}
    for ds, src in zip(datasets, sources, strict=True):
        for name in map(str, ds["scan"].values):
            if name in seen:
                raise InputError(f"{seen[name]} and {src} both hold the scan {name!r}: "
                                 "combining them would drop one")
            seen[name] = src


def _concat_scans(datasets: Sequence[xr.Dataset]) -> xr.Dataset:
    """Leak datasets concatenated along ``scan`` (sorted by name), outer-joined on the
    other coordinates (``pressure``): a variable gains no dimension it does not have."""
    order = sorted(range(len(datasets)), key=lambda i: str(datasets[i]["scan"].values[0]))
    out = xr.concat([datasets[i] for i in order], dim="scan", data_vars="minimal",
                    coords="minimal", compat="override", join="outer",
                    combine_attrs="drop_conflicts")
    if not out.indexes["pressure"].is_monotonic_increasing:
        out = out.sortby("pressure")
    # drop_conflicts keeps an attribute that only some scans have (a scan's source file on
    # a study with a generated surface): it survives only where every scan has it alike
    out.attrs = {k: v for k, v in out.attrs.items() if all(k in ds.attrs for ds in datasets)}
    return out


def _same(a, b) -> bool:
    """Two values alike: numpy arrays element by element, NaN equal to NaN (a ladder's
    a_c_star_alt without a second threshold is NaN in every job)."""
    try:
        return bool(np.array_equal(np.asarray(a), np.asarray(b), equal_nan=True))
    except (TypeError, ValueError):  # text: no NaN to compare
        return bool(np.array_equal(np.asarray(a), np.asarray(b)))


def combine(datasets: Sequence[xr.Dataset], sources: Sequence[str] | None = None) -> xr.Dataset:
    """Outer combination by coordinates (``xr.combine_by_coords``, falling back to merge) of
    job datasets of one scene that fill disjoint cells (:func:`check_disjoint`)."""
    if not datasets:
        raise InputError("nothing to aggregate: no datasets given")
    if sources is None:
        sources = [f"dataset {i}" for i in range(len(datasets))]
    kinds = [check_kind(ds, JOB_KINDS, src) for ds, src in zip(datasets, sources, strict=True)]
    if len(set(kinds)) > 1:
        i = next(i for i, k in enumerate(kinds) if k != kinds[0])
        raise InputError(f"cannot combine {sources[0]} ({kinds[0]}) with {sources[i]} "
                         f"({kinds[i]}): a study dataset holds one scene")
    if kinds[0] == "leak_job":
        _check_scans_disjoint(datasets, sources)
        datasets = with_scan_variables(datasets)
    else:
        check_disjoint(datasets, sources)
    # integer variables arrive as int (no missing values) or, decoded with a fill value,
    # as float with an integer on-disk dtype in their encoding
    int_vars = {name for ds in datasets for name, v in ds.data_vars.items()
                if v.dtype.kind in "iu" or np.dtype(v.encoding.get("dtype", "f8")).kind in "iu"}
    if len(datasets) == 1:
        out = datasets[0].copy()
    elif kinds[0] == "leak_job":
        out = _concat_scans(datasets)
    else:
        try:
            # compat and coords as today's defaults, which xarray is about to change
            # data_vars "minimal": a variable is concatenated along a dimension only where
            # it has it; "all" gave the per-job nx, ny, ... a seed dimension wherever jobs
            # of one setting were split into seed groups (summing nx * ny counted 10x), and
            # every variable a step dimension where ladders differ in length (3 and 4
            # steps: a ladder's wall time repeated per step). join "outer" fills a shorter
            # ladder's missing steps with NaN.
            out = xr.combine_by_coords(list(datasets), join="outer", compat="no_conflicts",
                                       coords="different", combine_attrs="drop_conflicts",
                                       data_vars="minimal")
        except ValueError as exc:
            log.info("combine_by_coords failed (%s); merging instead", exc)
            out = xr.merge(list(datasets), join="outer", compat="no_conflicts",
                           combine_attrs="drop_conflicts")
        # drop_conflicts keeps an attribute that only some jobs have, as if it held for all,
        # and one that differs between groups combine_by_coords makes first (a job's id
        # and command line survived in a study of three models)
        out.attrs = {k: v for k, v in out.attrs.items()
                     if all(k in ds.attrs and _same(ds.attrs[k], v) for ds in datasets)}
    # sorted: the study's attributes do not depend on the order its files were listed in
    ids = sorted(str(ds.attrs.get("job_id", "")) for ds in datasets)
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


def aggregate(inputs: Sequence[str | os.PathLike | xr.Dataset], output: str | os.PathLike,
              *, study: str | None = None, sources: Sequence[str] | None = None,
              provenance: Provenance | None = None) -> xr.Dataset:
    """Load (paths) or take (datasets) the job datasets, combine them and atomically write
    the study dataset (with ``provenance``); returns it. ``sources`` name the inputs in
    messages."""
    if sources is None:
        sources = [repr(str(p)) if not isinstance(p, xr.Dataset) else f"dataset {i}"
                   for i, p in enumerate(inputs)]
    datasets = [p if isinstance(p, xr.Dataset) else load(p, JOB_KINDS) for p in inputs]
    out = combine(datasets, sources)
    if study is not None:
        out.attrs["study"] = study
    out.attrs["title"] = f"roughflow study {study or ''}".strip()
    if provenance is None:
        provenance = default_provenance(out)
    inherited = settings_of_inputs(*datasets)
    for key, value in inherited:
        if str(value).startswith("mixed"):  # e.g. jobs run before and after a code change
            log.warning("the jobs of %s differ in %s (%s): rerun the older ones for one "
                        "consistent study (snakemake --forcerun)", output, key, value)
    failed, ran = unbracketed_searches(out)
    if failed:
        log.warning("%d of %d threshold searches (seed and axis) in %s did not bracket a_c* "
                    "(NaN, left out of the seed means and fits): their job logs say why",
                    failed, ran, output)
    write_dataset(out, output, provenance=replace(provenance, from_inputs=inherited))
    log.info("aggregated %d datasets into %s (%s)", len(datasets), output,
             dict(out.sizes))
    return out
