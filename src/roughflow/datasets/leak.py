"""The dataset of a leak question (``roughflow leak``, the ``measured`` study).

Dimensions ``scan`` (length 1 per file; the aggregation of a study concatenates scans),
``pressure`` (the nominal contact pressures, coordinate in Pa) and ``axis`` (flow along x
or y). The dimensionless results keep their reference units (L, E*, eta) with the SI
values as attributes (:data:`~roughflow.datasets.units.REFERENCE_ATTRS`) and, since those
differ between scans, also as variables over ``scan``; the physical answers (conductance,
leak rate, sealing pressure) are stored in SI units as well.

A study dataset (``roughflow aggregate``) concatenates leak files along ``scan`` and keeps
what describes each scan as variables over ``scan`` (:func:`with_scan_variables`): always
those of :data:`SCAN_ATTRS` (boundary treatment, question, scan provenance), and any other
attribute whose value differs between the scans; the attributes survive only where all
scans agree.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
import xarray as xr

from roughflow.provenance import PROVENANCE_ATTRS

from .results import (
    AXIS_COORD,
    AXIS_NAMES,
    FLOW_IMBALANCE_LONG_NAME,
    FLOW_SIGMA_ERROR_LONG_NAME,
    spec_attrs,
)
from .units import (
    CONDUCTANCE_SI,
    DIMENSIONLESS,
    FLOW_RATE_SI,
    INT_FILL,
    LENGTH_UNITS,
    METRES,
    PASCAL,
    PASCAL_SECONDS,
    PRESSURE_UNITS,
    REF_LENGTH,
    REF_PRESSURE,
    REF_VISCOSITY,
    REFERENCE_ATTRS,
    REFERENCE_VARIABLES,
    RESIDUAL_UNITS,
    SIGMA_UNITS,
    flags,
)

log = logging.getLogger(__name__)

if TYPE_CHECKING:
    from roughflow.leak import LeakCurve
    from roughflow.surface import Surface
    from roughflow.units import Scales



def _int(dims, values, attrs) -> xr.Variable:
    v = xr.Variable(dims, np.asarray(values).astype(np.int32), attrs)
    v.encoding = {"_FillValue": np.int32(INT_FILL), "dtype": "int32"}
    return v


def leak_dataset(curve: LeakCurve, surface: Surface, *, scales: Scales, fluid_pressure: float,
                 seal_width: float, seal_length: float, name: str) -> xr.Dataset:
    """The leak curve of ``surface`` in dimensionless and SI units (module docstring).

    ``scales``: L (m), E* (Pa), eta (Pa s); ``fluid_pressure`` (Pa): the pressure drop
    across the seal; ``seal_width`` (m, along the flow) and ``seal_length`` (m, across it);
    ``name``: the scan's label (the ``scan`` coordinate). Bad values raise
    :class:`~roughflow.errors.InputError` (:func:`roughflow.leak.check_seal`).
    """
    from roughflow.leak import check_seal, fluid_pressure_note
    from roughflow.units import leak_rate

    check_seal(surface, scales, fluid_pressure=fluid_pressure, seal_width=seal_width,
               seal_length=seal_length)
    pressures_si = scales.pressure_to_si(curve.pressure)
    fluid_note = fluid_pressure_note(fluid_pressure, pressures_si, unit="Pa")
    if fluid_note:
        log.warning("%s: %s", name, fluid_note)
    conductance = scales.conductance_to_si(curve.sigma)
    rate = leak_rate(conductance, fluid_pressure=fluid_pressure, seal_width=seal_width,
                     seal_length=seal_length)
    th = [curve.thresholds.get(a) for a in (0, 1)]

    def thr(field: str) -> np.ndarray:
        return np.array([[np.nan if t is None else float(getattr(t, field)) for t in th]])

    # a sealing search capped at a hardness (leak_curve(..., hardness=)) says so in the
    # names of its variables: its thresholds are not the elastic contact's
    capped = next((t.hardness for t in th if t is not None and t.hardness is not None), None)
    of = ("" if capped is None else
          " (elastic-perfectly-plastic contact, pressure capped at the hardness: hardness_Pa)")

    sp, spa = ("scan", "pressure"), ("scan", "pressure", "axis")
    sa = ("scan", "axis")
    data = {
        "pressure_dimensionless": (sp, curve.pressure[None], {
            "units": PRESSURE_UNITS, "long_name": "nominal contact pressure in units of E* "
                                                  "(the solver's pressure)"}),
        "area_fraction": (sp, curve.area_fraction[None], {
            "units": DIMENSIONLESS, "long_name": "relative contact area a_c"}),
        "mean_gap": (sp, curve.mean_gap[None], {
            "units": LENGTH_UNITS, "long_name": "mean interfacial gap"}),
        "mean_gap_si": (sp, scales.length_to_si(curve.mean_gap)[None], {
            "units": METRES, "long_name": "mean interfacial gap in metres (mean_gap times "
                                          "the reference length)"}),
        "percolating": _int(spa, curve.percolating[None], {
            "units": DIMENSIONLESS, "long_name": "1 if the fluid spans the analysed window "
                                                 "along axis (the seal leaks)",
            **flags("sealed leaking")}),
        "sigma": (spa, curve.sigma[None], {
            "units": SIGMA_UNITS, "long_name": "effective conductance u^3/(12 eta) along axis "
                                               "(Eq. 3-4; 0 where the fluid does not span)"}),
        "conductance": (spa, conductance[None], {
            "units": CONDUCTANCE_SI, "long_name": "effective conductance along axis per unit "
                                                  "width per unit pressure gradient"}),
        "leak_rate": (spa, rate[None], {
            "units": FLOW_RATE_SI,
            "long_name": "volume leak rate Q = conductance * seal_length * fluid_pressure / "
                         "seal_width for flow along axis"}),
        "contact_iterations": _int(sp, curve.iterations[None], {
            "units": DIMENSIONLESS, "long_name": "iterations of the contact solve"}),
        "contact_residual": (sp, curve.residual[None], {
            "units": RESIDUAL_UNITS, "long_name": "residual of the contact solve (largest gap "
                                                  "error / rms height)"}),
        "flow_imbalance": (spa, curve.flow_imbalance[None], {
            "units": DIMENSIONLESS, "long_name": FLOW_IMBALANCE_LONG_NAME}),
        "flow_sigma_error": (spa, curve.flow_sigma_error[None], {
            "units": DIMENSIONLESS, "long_name": FLOW_SIGMA_ERROR_LONG_NAME}),
        "a_c_star": (sa, thr("a_c_star"), {
            "units": DIMENSIONLESS, "long_name": "critical contact area a_c* where the fluid "
                                                 f"stops spanning along axis{of}"}),
        "sealing_pressure": (sa, scales.pressure_to_si(thr("p_hi")), {
            "units": PASCAL, "long_name": "sealing pressure along axis: lowest nominal "
                                          "pressure found sealed (the fluid no longer "
                                          f"spans){of}"}),
        "sealing_pressure_lo": (sa, scales.pressure_to_si(thr("p_lo")), {
            "units": PASCAL, "long_name": "highest nominal pressure found leaking along axis "
                                          "(the seal closes between this and "
                                          f"sealing_pressure){of}"}),
        "bracketed": _int(sa, np.array([[0 if t is None else int(t.bracketed) for t in th]]), {
            "units": DIMENSIONLESS, "long_name": "1 if the sealing search found both sides "
                                                 "within its pressure range",
            **flags("not_bracketed bracketed")}),
        REFERENCE_VARIABLES[REF_LENGTH]: ("scan", [scales.length], {
            "units": METRES, "long_name": "reference length L (lengths are in units of L)"}),
        REFERENCE_VARIABLES[REF_PRESSURE]: ("scan", [scales.modulus], {
            "units": PASCAL, "long_name": "contact modulus E* (pressures are in units of E*)"}),
        "rms_gradient": ("scan", [curve.rms_gradient], {
            "units": DIMENSIONLESS, "long_name": "rms gradient gbar of the surface"}),
    }
    if curve.plastic_fraction is not None:  # rows solved with a hardness (leak_curve)
        data["plastic_fraction"] = (sp, curve.plastic_fraction[None], {
            "units": DIMENSIONLESS, "long_name": "plastic share of the analysed window: cells "
                                                 "whose pressure is at the hardness (part of "
                                                 "area_fraction)"})
    coords = {
        "scan": ("scan", [name], {"long_name": "scan"}),
        "pressure": ("pressure", pressures_si, {
            "units": PASCAL, "long_name": "nominal contact pressure"}),
        "axis": ("axis", list(AXIS_NAMES[:2]), AXIS_COORD[2]),
    }
    ds = xr.Dataset(data, coords=coords)
    ds["pressure"].encoding["_FillValue"] = None
    messages = " | ".join(t.message for t in th if t is not None and t.message) or "none"
    ds.attrs = {
        **spec_attrs(surface), "title": "roughflow leak", "boundary": curve.boundary,
        "boundary_description": BOUNDARY_TEXT.get(curve.boundary, curve.boundary),
        **scales.attrs(),
        "fluid_pressure_Pa": float(fluid_pressure), "seal_width_m": float(seal_width),
        "seal_length_m": float(seal_length), "fluid_pressure_note": fluid_note,
        "pressure_reference": "dimensionless pressures are in units of E*; the surface keeps "
                              f"its rms gradient gbar = {curve.rms_gradient:.6g}",
        "window_nx": int(curve.window_shape[0]), "window_ny": int(curve.window_shape[1]),
        "window_lx": curve.window_lx, "window_ly": curve.window_ly,
        "lx": surface.lx, "ly": surface.ly, "sealing_messages": messages,
        **curve.settings,
    }
    if "hardness" in curve.settings:  # E*, as the curve's pressures
        ds.attrs["hardness_Pa"] = float(scales.pressure_to_si(curve.settings["hardness"]))
    return ds


#: One line per boundary method, for the datasets (roughflow.boundary has the details).
BOUNDARY_TEXT = {
    "mirror": "non-periodic scan mirror-tiled to 2x2; the scan's quadrant analysed with walls "
              "across the flow",
    "pad": "non-periodic scan padded by a flat region far below it (2x2 cell); the scan "
           "analysed with walls across the flow",
    "window": "scan solved as periodic; an interior window analysed with walls across the flow",
    "periodic": "the surface taken as periodic",
}


#: Attributes of a leak file that describe its scan, kept in a study dataset as variables
#: over ``scan`` (they may differ between scans): attribute -> (variable, units, long_name).
#: ``ref_length_m`` and ``ref_pressure_Pa`` are there as ``length_scale`` and ``modulus``
#: (:data:`~roughflow.datasets.units.REFERENCE_VARIABLES`).
SCAN_ATTRS: dict[str, tuple[str, str, str]] = {
    "boundary": ("boundary", DIMENSIONLESS,
                 "non-periodic treatment of the scan (roughflow leak --boundary)"),
    "boundary_description": ("boundary_description", DIMENSIONLESS,
                             "what the boundary treatment of the scan does"),
    REFERENCE_ATTRS[REF_VISCOSITY][0]: (
        REFERENCE_VARIABLES[REF_VISCOSITY], PASCAL_SECONDS,
        "fluid viscosity eta (viscosities are in units of eta)"),
    "fluid_pressure_Pa": ("fluid_pressure", PASCAL, "fluid pressure drop across the seal"),
    "seal_width_m": ("seal_width", METRES, "seal width w (along the flow)"),
    "seal_length_m": ("seal_length", METRES, "seal length l (across the flow)"),
    "surface_file": ("surface_file", DIMENSIONLESS, "surface file the leak curve was run on"),
    "scan_source": ("scan_source", DIMENSIONLESS, "file the scan was imported from"),
    "scan_reader": ("scan_reader", DIMENSIONLESS, "reader of the scan file"),
    "scan_channel": ("scan_channel", DIMENSIONLESS, "channel of the scan file"),
    "scan_length_scale": ("scan_length_scale", METRES,
                          "reference length L of the imported scan"),
    "scan_rms_gradient": ("scan_rms_gradient", DIMENSIONLESS,
                          "rms gradient of the imported scan"),
    "scan_detrend": ("scan_detrend", DIMENSIONLESS, "detrending of the imported scan"),
    "scan_fill": ("scan_fill", DIMENSIONLESS, "filling of missing points of the scan"),
    "scan_filled": ("scan_filled", DIMENSIONLESS, "number of missing points filled"),
    "scan_crop": ("scan_crop", DIMENSIONLESS, "grid window kept of the scan"),
    "scan_periodic": ("scan_periodic", DIMENSIONLESS, "1 if the scan is taken as periodic"),
}
#: CF flags of the yes/no variables among :data:`SCAN_ATTRS`.
SCAN_FLAGS = {"scan_periodic": flags("aperiodic periodic")}

#: Attributes that are not about a scan (provenance, the study) or that are variables of a
#: leak file already; they never become variables over ``scan``.
NOT_PER_SCAN = frozenset({*PROVENANCE_ATTRS, "title", "job_id", "jobs", "n_jobs", "study",
                          "ref_length_m", "ref_pressure_Pa"})

#: Units of other attributes (by name, else by the suffix of the name; else "1").
_OTHER_UNITS = {"lx": LENGTH_UNITS, "ly": LENGTH_UNITS, "window_lx": LENGTH_UNITS,
                "window_ly": LENGTH_UNITS}
_SUFFIX_UNITS = (("_Pa_s", PASCAL_SECONDS), ("_Pa", PASCAL), ("_m", METRES))


def _units(attr: str) -> str:
    if attr in _OTHER_UNITS:
        return _OTHER_UNITS[attr]
    return next((u for suffix, u in _SUFFIX_UNITS if attr.endswith(suffix)), DIMENSIONLESS)


def _attr_variable(value, n: int, kind: str, attrs: dict) -> xr.Variable:
    """The attribute ``value`` repeated over ``n`` scans as text, integer or float
    (``kind`` "U", "i", "f"); missing (None): "", :data:`INT_FILL` (the integer fill
    value) or NaN."""
    if kind == "U":
        return xr.Variable("scan", np.array(["" if value is None else str(value)] * n), attrs)
    if kind == "i":
        return _int("scan", [INT_FILL if value is None else int(value)] * n, attrs)
    return xr.Variable("scan", np.full(n, np.nan if value is None else float(value)), attrs)


def with_scan_variables(datasets: Sequence[xr.Dataset]) -> list[xr.Dataset]:
    """Copies of leak datasets to be concatenated along ``scan``, each with the variables
    over ``scan`` of its per-scan attributes (module docstring): those of
    :data:`SCAN_ATTRS` that any dataset has, and every other attribute (not
    :data:`NOT_PER_SCAN`) whose value differs between the datasets or that some lack. A
    dataset that holds such a variable already (a study dataset) keeps it."""
    names = list(dict.fromkeys(a for ds in datasets for a in ds.attrs))
    per_scan = {}
    for attr in names:
        values = [ds.attrs.get(attr) for ds in datasets]
        if attr in SCAN_ATTRS:
            var, units, long_name = SCAN_ATTRS[attr]
        elif attr in NOT_PER_SCAN or all(
                v is not None and np.array_equal(v, values[0]) for v in values):
            continue
        else:
            var, units, long_name = attr, _units(attr), f"the leak file's {attr!r} attribute"
        given = [v for v in values if v is not None]
        kinds = {np.asarray(v).dtype.kind for v in given}
        kind = "U" if kinds - set("biuf") else "f" if "f" in kinds else "i"
        per_scan[attr] = (var, kind, {"units": units, "long_name": long_name,
                                      **SCAN_FLAGS.get(attr, {})})
    out = []
    for ds in datasets:
        ds = ds.copy()
        for attr, (var, kind, attrs) in per_scan.items():
            if var not in ds.variables:
                ds[var] = _attr_variable(ds.attrs.get(attr), ds.sizes["scan"], kind, attrs)
        out.append(ds)
    return out
