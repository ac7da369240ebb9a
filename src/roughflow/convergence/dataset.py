"""The accuracy study's records as one self-describing netCDF dataset.

When a run of ``roughflow accuracy resolution`` or ``tol`` completes, its whole record log
(:mod:`.records`, JSON lines) is written as a dataset beside it (:func:`write_records_dataset`,
atomically); the reports read the datasets (:func:`read_records`).

Layout: the dimension ``record`` (the records in the log's order) and one variable per field
of the records over it, named as the field (``kind``, ``seed``, ``a_star_0``, ...), with
``units`` (numbers) and ``long_name`` (:data:`FIELDS`, :data:`AXIS_FIELDS`): integers as
int64 (with the fill value ``INT_FILL`` only where some record lacks the value: xarray reads
such a column as float64, exact up to 2^53; the seeds and grids are in every record), other
numbers as float64 (fill NaN), text as strings (fill ""). The fields that set a
measurement up (seed, grid, target, tolerances) are coordinates.
Not every record has every field: the coordinate ``field`` names the fields, and the flag
variable ``field_state`` (record, field) says for each record whether it has the field
(absent, a value, NaN included, or null: JSON null, Python None). :func:`records_from_dataset`
so restores the records exactly: the same keys and values (a field that holds integers in
some records and other numbers in others comes back as floats, equal in value).
"""

from __future__ import annotations

import numbers
import os
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import xarray as xr

from roughflow.citation import threshold_methods
from roughflow.datasets.results import FLOW_IMBALANCE_LONG_NAME, THRESHOLD_FIELDS
from roughflow.datasets.units import (
    DIMENSIONLESS,
    INT_FILL,
    LENGTH_UNITS,
    PRESSURE_UNITS,
    RESIDUAL_UNITS,
    SECONDS,
    SIGMA_UNITS,
    flags,
)
from roughflow.defaults import AXIS_NAMES
from roughflow.errors import InputError
from roughflow.provenance import Provenance

from .records import dataset_file, load_records

#: the two studies: the ``study`` attribute and the title of their datasets
STUDIES = ("resolution", "tolerance")
#: the methods behind both studies' numbers (their ``references``)
METHODS = ("surface", *threshold_methods("elastic"), "reynolds")

RECORD, FIELD, STATE = "record", "field", "field_state"
#: the values of ``field_state``: the record lacks the field, holds a value, holds null
ABSENT, VALUE, NULL = 0, 1, 2
STATE_FLAGS = flags("absent value null", np.int8)

#: every field of the records but the per-axis ones: name -> (units, None for text;
#: long_name; whether it sets the measurement up: a coordinate)
FIELDS: dict[str, tuple[str | None, str, bool]] = {
    "kind": (None, "what the record measured: threshold, sigma or fixed (resolution study); "
                   "contact_tol, threshold_contact_tol or bisect_tol, with _failed where the "
                   "search did not converge (tolerance study)", True),
    "seed": (DIMENSIONLESS, "seed of the surface", True),
    "ppl": (DIMENSIONLESS, "grid points per lambda_s", True),
    "n": (DIMENSIONLESS, "grid points along x", True),
    "ny": (DIMENSIONLESS, "grid points along y", True),
    "gamma": (DIMENSIONLESS, "Peklenik number of the surface", True),
    "l_over_lambda_r": (DIMENSIONLESS, "L / lambda_r of the surface (null: the paper's)", True),
    "dx": (LENGTH_UNITS, "grid spacing along x", True),
    "dy": (LENGTH_UNITS, "grid spacing along y", True),
    "target": (DIMENSIONLESS, "contact area fraction the record aims at: the load search's "
                              "target (sigma), the area whose contact-law load is solved "
                              "(fixed, contact_tol)", True),
    "p": (PRESSURE_UNITS, "the contact law's load for the target (contact_tol)", True),
    "bisect_tol": (DIMENSIONLESS, "bisection tolerance a_hi - a_lo of the threshold search",
                   True),
    "contact_tol": (RESIDUAL_UNITS, "contact solver tolerance (gap error / rms height): of the "
                                    "threshold search (threshold, threshold_contact_tol, "
                                    "bisect_tol), of the fixed-load and fixed-area solves "
                                    "(sigma, fixed, contact_tol)", True),
    "area_tol": (DIMENSIONLESS, "how close the load search brings a_c to the target (sigma)",
                 True),
    "time": (SECONDS, "wall time of the threshold search, both axes", False),
    "n_solves": (DIMENSIONLESS, THRESHOLD_FIELDS["n_solves"][1], False),
    "time_mid": (SECONDS, "wall time of one contact solve at a bracket's midpoint load "
                          "(mean over the axes)", False),
    "perim_mid": (DIMENSIONLESS, "mean of the perimeter terms perim_0 and perim_1", False),
    "p_fixed": (PRESSURE_UNITS, "the contact law's load for the target: the load search's "
                                "first solve (sigma), the solve (fixed)", False),
    "a_fixed": (DIMENSIONLESS, "contact area fraction at p_fixed", False),
    "gap_fixed": (LENGTH_UNITS, "mean gap at p_fixed", False),
    "perim_fixed": (DIMENSIONLESS, "perimeter term (contact/non-contact faces per cell, "
                                   "roughflow.accuracy.perimeter_term) at p_fixed", False),
    "tx_fixed": (DIMENSIONLESS, "contact/non-contact faces normal to x per cell at p_fixed",
                 False),
    "ty_fixed": (DIMENSIONLESS, "contact/non-contact faces normal to y per cell at p_fixed",
                 False),
    "a": (DIMENSIONLESS, "contact area fraction: of the load search's last solve, within "
                         "area_tol of the target (sigma); at the load p (contact_tol)", False),
    "perim": (DIMENSIONLESS, "perimeter term of the load search's last solve", False),
    "sigma_raw": (SIGMA_UNITS, "effective conductance sigma_x at the contact area a", False),
    "sigma": (SIGMA_UNITS, "effective conductance sigma_x: sigma_raw moved onto a_c = target "
                           "along the load path (Eq. 16 slope; sigma); at the load p "
                           "(contact_tol)", False),
    "mean_gap": (LENGTH_UNITS, "mean gap: of the load search's last solve (sigma); at the "
                               "load p (contact_tol)", False),
    "n_contact_solves": (DIMENSIONLESS, "contact solves of the load search", False),
    "iterations": (DIMENSIONLESS, "contact solver iterations", False),
    "time_contact": (SECONDS, "wall time of the contact solves: the load search (sigma), the "
                              "solve (fixed, contact_tol)", False),
    "time_flow": (SECONDS, "wall time of the flow solve", False),
    "flow_residual": (DIMENSIONLESS, "relative residual of the flow solve's linear system",
                      False),
    "flux_imbalance": (DIMENSIONLESS, FLOW_IMBALANCE_LONG_NAME, False),
    "error": (None, "why the threshold search failed (_failed records)", False),
}
#: the per-axis fields ``NAME_0`` (x) and ``NAME_1`` (y): name -> (units, long_name)
AXIS_FIELDS: dict[str, tuple[str, str]] = {
    "a_star": (DIMENSIONLESS, THRESHOLD_FIELDS["a_c_star"][1]),
    "a_star_corrected": (DIMENSIONLESS, "a_c* with the search's perimeter correction"),
    "a_lo": THRESHOLD_FIELDS["a_lo"],
    "a_hi": THRESHOLD_FIELDS["a_hi"],
    "width": (DIMENSIONLESS, "width a_hi - a_lo of the threshold's bracket"),
    "a_mid": (DIMENSIONLESS, "contact area fraction at the midpoint of the bracket's loads "
                             "(NaN: no bracket)"),
    "perim": (DIMENSIONLESS, "perimeter term at the midpoint of the bracket's loads"),
    "tx": (DIMENSIONLESS, "contact/non-contact faces normal to x per cell at the midpoint of "
                          "the bracket's loads"),
    "ty": (DIMENSIONLESS, "contact/non-contact faces normal to y per cell at the midpoint of "
                          "the bracket's loads"),
}


def describe(name: str) -> tuple[str | None, str, bool]:
    """(units, long_name, coordinate) of the record field ``name``; :class:`InputError`
    for a field this module does not know (a log of another roughflow version)."""
    if name in FIELDS:
        return FIELDS[name]
    base, _, axis = name.rpartition("_")
    if base in AXIS_FIELDS and axis in ("0", "1"):
        units, long_name = AXIS_FIELDS[base]
        return units, f"along {AXIS_NAMES[int(axis)]}: {long_name}", False
    raise InputError(f"record field {name!r} is not a field of the accuracy study's records "
                     "(roughflow.convergence.dataset.FIELDS): a record log of another "
                     "roughflow version?")


def _column(name: str, values: list) -> xr.Variable:
    """The variable of field ``name`` over ``record``; ``values`` None where a record has
    no value (absent or null)."""
    given = [v for v in values if v is not None]
    units, long_name, _ = describe(name)
    attrs = {"long_name": long_name} if units is None else {"units": units,
                                                            "long_name": long_name}
    if given and all(isinstance(v, str) for v in given):
        return xr.Variable(RECORD, np.array(["" if v is None else v for v in values],
                                            dtype=object), attrs)
    if not all(isinstance(v, numbers.Real) and not isinstance(v, (bool, np.bool_))
               for v in given):
        kinds = sorted({type(v).__name__ for v in given})
        raise InputError(f"record field {name!r} holds {', '.join(kinds)} values: only "
                         "numbers, text and null are stored")
    # an integer field whose values include the fill value is stored as floats: the fill
    # would read back as missing
    if given and all(isinstance(v, numbers.Integral) for v in given) and INT_FILL not in given:
        v = xr.Variable(RECORD, np.array([INT_FILL if v is None else int(v) for v in values],
                                         dtype=np.int64), attrs)
        # a fill value only where a record lacks the value: xarray reads an integer
        # variable with one as float64, which rounds integers beyond 2^53 (a seed)
        v.encoding = {"_FillValue": np.int64(INT_FILL) if None in values else None,
                      "dtype": "int64"}
        return v
    return xr.Variable(RECORD, np.array([np.nan if v is None else float(v) for v in values],
                                        dtype=np.float64), attrs)


def records_to_dataset(records: Sequence[Mapping], *, study: str) -> xr.Dataset:
    """The records of the ``study`` (:data:`STUDIES`) as one dataset (module docstring);
    :class:`InputError` for a field that is not the study's or a value that is neither a
    number nor text."""
    if study not in STUDIES:
        raise ValueError(f"study must be one of {STUDIES}, got {study!r}")
    names = list(dict.fromkeys(k for r in records for k in r))
    clash = [n for n in names if n in (RECORD, FIELD, STATE)]
    if clash:
        raise InputError(f"record field {clash[0]!r} is a name of the dataset's layout")
    state = np.array([[ABSENT if n not in r else NULL if r[n] is None else VALUE
                       for n in names] for r in records], dtype=np.int8)
    state = state.reshape(len(records), len(names))
    variables = {n: _column(n, [r.get(n) for r in records]) for n in names}
    ds = xr.Dataset(
        {n: v for n, v in variables.items() if not describe(n)[2]},
        coords={FIELD: (FIELD, np.array(names, dtype=object),
                        {"long_name": "name of a field of the records (the variable of that "
                                      "name)"}),
                **{n: v for n, v in variables.items() if describe(n)[2]}},
        attrs={"title": f"roughflow accuracy study: {study} records", "study": study,
               "comment": f"one measurement per {RECORD} (a line of the record log, in "
                          f"its order); {STATE} says which fields each record has"})
    ds[STATE] = ((RECORD, FIELD), state, {
        "units": DIMENSIONLESS,
        "long_name": "whether each record has each field: absent (its variable holds the fill "
                     "value), a value, or null (JSON null)", **STATE_FLAGS})
    return ds


def _is_integer(v: xr.DataArray) -> bool:
    """Whether field variable ``v`` holds integers: int64 in the file (read with the default
    decoding, a variable with a fill value comes back as floats)."""
    return np.dtype(v.encoding.get("dtype", v.dtype)).kind in "iu"


def records_from_dataset(ds: xr.Dataset, *, source: str = "the dataset") -> list[dict]:
    """The records of a dataset of :func:`records_to_dataset` (read from ``source``, named in
    messages): the same list of dicts; :class:`InputError` where ``ds`` is no such
    dataset."""
    missing = [n for n in (FIELD, STATE) if n not in ds.variables]
    if missing:
        raise InputError(f"{source} holds no records of the accuracy study (no "
                         f"{' or '.join(map(repr, missing))} variable)")
    names = [str(n) for n in ds[FIELD].values]
    lacking = [n for n in names if n not in ds.variables]
    if lacking:
        raise InputError(f"{source}: damaged records (no variable of the fields {lacking})")
    state = ds[STATE].transpose(RECORD, FIELD).values
    if not np.isin(state, (ABSENT, VALUE, NULL)).all():
        raise InputError(f"{source}: damaged records ({STATE} holds values other than "
                         f"{ABSENT}, {VALUE}, {NULL})")
    columns = []
    for n in names:
        values = ds[n].values
        convert = (str if values.dtype.kind in "OUS" else int if _is_integer(ds[n])
                   else float)
        columns.append((n, values, convert))
    return [{n: None if s[j] == NULL else convert(values[i])
             for j, (n, values, convert) in enumerate(columns) if s[j] != ABSENT}
            for i, s in enumerate(state)]


def write_records_dataset(log: str | os.PathLike, *, study: str,
                          provenance: Provenance | None = None) -> Path:
    """The whole record log ``log`` of the ``study`` as a dataset beside it
    (:func:`~.records.dataset_file`), written atomically with the attributes of
    ``provenance`` (default: the Python API's) citing :data:`METHODS`; returns its path."""
    from roughflow.io import write_dataset

    log = Path(log)
    ds = records_to_dataset(load_records(log), study=study)
    ds.attrs["records_log"] = log.name
    return write_dataset(ds, dataset_file(log),
                         provenance=(provenance or Provenance()).using(*METHODS))


def read_records(path: str | os.PathLike) -> list[dict]:
    """The records of the dataset ``path`` (:func:`write_records_dataset`); InputError naming
    the file where it is unreadable or holds no records."""
    from roughflow.io import read_dataset

    ds = read_dataset(path, what="accuracy study dataset")
    return records_from_dataset(ds, source=f"accuracy study dataset {str(path)!r}")
