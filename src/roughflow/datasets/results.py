"""xarray datasets of single results: a contact solve, a threshold search, a flow solve.

The command line writes these, the scenes build on them, and a notebook can call them
directly. Every variable has ``units`` and ``long_name``; scalars of the result and the
surface's parameters are attributes.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING

import numpy as np
import xarray as xr

from roughflow.defaults import AXIS_NAMES, CORRECTION_MIN_POINTS, PERSSON_ENERGY_FACTOR
from roughflow.errors import InputError, check_axis

from .units import (
    AREAL_ENERGY_UNITS,
    CONTACT_FLAGS,
    DIMENSIONLESS,
    FLUID_PRESSURE_UNITS,
    FLUX_UNITS,
    LENGTH_UNITS,
    PRESSURE_UNITS,
    REF_LENGTH,
    REFERENCE_ATTRS,
    SIGMA_UNITS,
    flags,
    grid_coords,
)

if TYPE_CHECKING:
    from roughflow.contact import Adhesion, ContactResult
    from roughflow.flow import FlowResult
    from roughflow.search import Threshold
    from roughflow.surface import Surface, SurfaceSpec
    from roughflow.theory import PerssonPrediction

#: The ``axis`` coordinate of every per-direction variable.
AXIS_COORD = ("axis", list(AXIS_NAMES), {"long_name": "flow / percolation direction "
                                                      "(x = axis 0, y = axis 1)"})

#: long names of a flow solve's diagnostics, shared by the datasets that record them per solve
#: (ladder scenes, leak curves)
FLOW_IMBALANCE_LONG_NAME = ("relative flux imbalance |Q_in - Q_out| / Q of the flow solve "
                            "(0 without a solve)")
FLOW_IMBALANCE_FLOOR_LONG_NAME = (
    "the flux imbalance float64 round-off alone leaves the flow solve's pressure (0 without a "
    "solve): an imbalance near it says nothing about sigma")
FLOW_SIGMA_ERROR_LONG_NAME = (
    "upper bound on the relative error of sigma from the flow solve: for direct solves from "
    "the residual (r^T A^-1 r / Q plus its round-off), or the complementary-energy bound where "
    "smaller; that bound for AMG-CG ones (no A^-1); 0 without a solve")


def spec_attrs(surface: Surface | SurfaceSpec) -> dict:
    """The surface's (or a spec's own) generation parameters as ``spec_*`` attributes, or
    for an imported scan its provenance as ``scan_*`` attributes plus the reference length
    in metres (empty for a bare height map)."""
    from roughflow.surface import SurfaceSpec

    out = {}
    spec = surface if isinstance(surface, SurfaceSpec) else getattr(surface, "spec", None)
    if spec is not None:
        out.update({f"spec_{k}": v for k, v in spec.as_attrs().items()})
    scan = getattr(surface, "scan", None)
    if scan is not None:
        out.update({f"scan_{k}": v for k, v in scan.as_attrs().items()})
        out[REFERENCE_ATTRS[REF_LENGTH][0]] = scan.length_scale
    return out


#: Flags of the plastic mask of a contact file (stored as int8).
PLASTIC_FLAGS = flags("not_plastic plastic", np.int8)


def contact_dataset(surface: Surface, result: ContactResult,
                    adhesion: Adhesion | None = None, *, tol: float | None = None) -> xr.Dataset:
    """Gap, contact mask, contact pressure (not for the bearing model, which has none) and
    heights on (x, y); scalars as attributes, with ``tol``, the solve's residual tolerance,
    where given (a ContactResult does not carry it: pass that of the solve). A result with
    a hardness adds the ``plastic`` mask and ``plastic_depth`` on (x, y) and the attributes
    ``hardness`` (in the units of ``pressure``) and ``plastic_fraction``.

    An adhesive result needs ``adhesion`` (the :class:`~roughflow.contact.Adhesion` it was
    solved with; the result does not record it), whose parameters become ``adhesion_*``
    attributes. A result whose grid is not the surface's raises :class:`InputError`; one of
    another surface of the same shape cannot be told apart (the result keeps no heights)."""
    nx, ny = surface.shape
    if np.shape(result.gap) != (nx, ny):
        raise InputError(f"contact_dataset: the result's grid {np.shape(result.gap)} is not "
                         f"the surface's {(nx, ny)} (a result of another surface?)")
    if result.model == "adhesive" and adhesion is None:
        raise InputError("contact_dataset: an adhesive result needs adhesion= (the Adhesion "
                         "it was solved with): without it the file records no adhesion")
    ds = xr.Dataset(
        {
            "gap": (("x", "y"), result.gap,
                    {"units": LENGTH_UNITS, "long_name": "interfacial gap u_g >= 0"}),
            "contact": (("x", "y"), result.contact.astype(np.int8),
                        {"units": DIMENSIONLESS, "long_name": "contact mask (1 = in contact)",
                         **CONTACT_FLAGS}),
            "contact_pressure": (("x", "y"), result.contact_pressure,
                                 {"units": PRESSURE_UNITS,
                                  "long_name": "local contact pressure (negative = tension)"}),
            "heights": (("x", "y"), surface.heights,
                        {"units": LENGTH_UNITS, "long_name": "height of the rigid rough surface"}),
        },
        coords=grid_coords(nx, ny, surface.lx, surface.ly),
        attrs={"title": "roughflow contact", "lx": surface.lx, "ly": surface.ly,
               "e_star": 1.0, **result.scalars(), **spec_attrs(surface)},
    )
    if adhesion is not None:
        ds.attrs.update(adhesion_attrs(surface, adhesion))
    if tol is not None and result.model != "bearing":  # a cut has no solver tolerance
        ds.attrs["tol"] = float(tol)
    if result.model == "bearing":  # a rigid cut carries no load: its zeros claimed one
        ds = ds.drop_vars("contact_pressure")
    if result.hardness is not None:  # elastic-perfectly-plastic (attrs from scalars())
        ds["plastic"] = (("x", "y"), result.plastic.astype(np.int8),
                         {"units": DIMENSIONLESS, **PLASTIC_FLAGS,
                          "long_name": "plastic cells (contact pressure at the hardness; "
                                       "part of the contact, gap 0)"})
        ds["plastic_depth"] = (("x", "y"), result.plastic_depth,
                               {"units": LENGTH_UNITS,
                                "long_name": "penetration of the rigid surface into the "
                                             "elastic surface on plastic cells (0 elsewhere)"})
    return ds


#: The adhesion's numbers (:func:`adhesion_attrs`, plus the range in lambda_s) as a sweep
#: dataset records them, per seed as variables (the ladder scene): each surface has its own
#: gamma_s (and R_c, v_ela^full), and the jobs of a study differ in model, so attributes
#: would hold only one job's first seed and were dropped or kept as if they held for all.
ADHESION_FIELDS = {
    "adhesion_surface_energy": (AREAL_ENERGY_UNITS, "surface energy gamma_s of the adhesion"),
    "adhesion_range": (LENGTH_UNITS, "range rho of the adhesive interaction"),
    "adhesion_contact_within": (DIMENSIONLESS, "a cell counts as in contact where its gap is "
                                               "below this many rho"),
    "adhesion_tabor": (DIMENSIONLESS, "Tabor parameter mu_T of the surface and adhesion"),
    "adhesion_curvature_radius": (LENGTH_UNITS, "R_c = 1 / rms curvature of the surface "
                                                "(Tabor parameter)"),
    "adhesion_v_ela_full": (AREAL_ENERGY_UNITS, "elastic energy per area of full contact "
                                                "v_ela^full"),
    "adhesion_gamma_over_v_full": (DIMENSIONLESS, "gamma_s / v_ela^full"),
    "adhesion_range_over_lambda_s": (DIMENSIONLESS, "range rho / lambda_s"),
}
#: The adhesion's wall (text), recorded per job next to :data:`ADHESION_FIELDS`.
ADHESION_REPULSION_FIELD = ("adhesion_repulsion",
                            "repulsive wall of the adhesive interaction (hard or harmonic)")


def adhesion_attrs(surface: Surface, adhesion: Adhesion) -> dict:
    """The adhesion of an adhesive result as attributes, all named ``adhesion_*``: surface
    energy, range, the wall and the contact criterion, and the derived numbers of
    ``contact.adhesion_summary`` (Tabor parameter, R_c, v_ela^full, gamma_s / v_ela^full).
    Contact, threshold and ladder files share these names."""
    from roughflow.contact import adhesion_summary

    summary = adhesion_summary(surface.heights, surface.lx, surface.ly, adhesion)
    return {"adhesion_surface_energy": adhesion.surface_energy,
            "adhesion_range": adhesion.range,
            "adhesion_repulsion": adhesion.repulsion,
            "adhesion_contact_within": adhesion.contact_within,
            **{f"adhesion_{k}": v for k, v in summary.items()}}


#: Per-axis variables of a threshold: name -> (units, long_name).
THRESHOLD_FIELDS = {
    "a_c_star": (DIMENSIONLESS, "percolation threshold a_c* (relative contact area, "
                                "estimated between a_lo and a_hi; docs/percolation.md)"),
    "a_c_star_corrected": (DIMENSIONLESS, "a_c* with the perimeter correction of the contact "
                                          "area (first-order grid bias removed, elastic "
                                          "model; the bearing model's cell count is unbiased: "
                                          "= a_c*; adhesive or capped at a hardness: not "
                                          "calibrated, NaN; "
                                          "calibrated on grids of at least "
                                          f"{CORRECTION_MIN_POINTS:g} points per lambda_s, "
                                          "over-shoots on coarser ones, where the figures "
                                          "take the raw a_c*; docs/accuracy.md)"),
    "a_lo": (DIMENSIONLESS, "largest contact area at which the fluid still percolates"),
    "a_hi": (DIMENSIONLESS, "smallest contact area at which the fluid no longer percolates"),
    "p_lo": (PRESSURE_UNITS, "pressure of a_lo"),
    "p_hi": (PRESSURE_UNITS, "pressure of a_hi"),
    "n_solves": (DIMENSIONLESS, "contact solves of the threshold search"),
    "bracketed": (DIMENSIONLESS, "1 if the threshold was bracketed within the pressure range"),
}


def _by_axis(func: str, results: Mapping, what: str) -> dict:
    """``results`` keyed by axis 0 / 1: each key (0, 1, ``"x"`` or ``"y"``) must name the
    axis the result itself records (``result.axis``), else :class:`InputError` naming both
    (a key alone labelled an x-flow passed under 1 ``sigma_y``)."""
    if not isinstance(results, Mapping):
        raise InputError(f"{func}: results must be a mapping of axis (0 / 'x', 1 / 'y') to "
                         f"{what}, got {type(results).__name__}")
    out = {}
    for key, r in results.items():
        try:
            ax = check_axis(key)
        except InputError as e:
            raise InputError(f"{func}: results key {key!r}: {e}") from None
        own = check_axis(r.axis)
        if own != ax:
            raise InputError(f"{func}: the {what} under key {key!r} (axis "
                             f"{AXIS_NAMES[ax]}) is along axis {AXIS_NAMES[own]} (its .axis "
                             f"= {r.axis!r})")
        if ax in out:
            raise InputError(f"{func}: axis {AXIS_NAMES[ax]} given twice (keys of results: "
                             f"{list(results)})")
        out[ax] = r
    return out


def threshold_dataset(results: Mapping[int | str, Threshold] | Threshold,
                      surface: Surface | None = None, *, solve_log: bool = True,
                      adhesion: Adhesion | None = None) -> xr.Dataset:
    """a_c*, its bracket and its pressures over ``axis`` (the axes in ``results``).

    ``results``: what :func:`roughflow.search.threshold` returns, a mapping of axis (0 or
    ``"x"``, 1 or ``"y"``) to :class:`~roughflow.search.Threshold` or a single one (one
    axis); each key must be the threshold's own ``axis`` (:class:`InputError` if not).
    With ``solve_log`` the contact solves of the search are listed over ``solve``; with
    ``adhesion`` (and ``surface``) its parameters are attributes, as for a contact; a search
    capped at a hardness (``Threshold.hardness``) records it as the attribute ``hardness``
    (E*, the units of ``p_lo`` and ``p_hi``), as a contact file does.
    """
    from roughflow.search import Threshold

    if adhesion is not None and surface is None:
        raise InputError("threshold_dataset: adhesion= needs the surface (its summary)")
    if isinstance(results, Threshold):  # search.threshold(surface, axis=...) returns one
        results = {results.axis: results}
    by_axis = _by_axis("threshold_dataset", results, "Threshold")
    if not by_axis:
        raise InputError("threshold_dataset: results is empty")
    axes = sorted(by_axis)
    r = [by_axis[a] for a in axes]
    data = {}
    for name, (units, long_name) in THRESHOLD_FIELDS.items():
        values = np.asarray([getattr(t, name) for t in r])
        attrs = {"units": units, "long_name": long_name}
        if values.dtype == bool:
            values = values.astype(np.int32)
            attrs.update(flags())
        data[name] = ("axis", values, attrs)
    ds = xr.Dataset(
        data,
        coords={"axis": ("axis", [AXIS_NAMES[a] for a in axes], AXIS_COORD[2])},
        attrs={"title": "roughflow percolation threshold", "model": r[0].model,
               "tol": r[0].tol, "n_solves": r[0].n_solves,
               "messages": " | ".join(t.message for t in r if t.message) or "none"},
    )
    if r[0].hardness is not None:
        ds.attrs["hardness"] = r[0].hardness
    if surface is not None:
        ds.attrs.update({"lx": surface.lx, "ly": surface.ly, **spec_attrs(surface)})
        if adhesion is not None:
            ds.attrs.update(adhesion_attrs(surface, adhesion))
    if solve_log and r[0].solves:
        s = np.asarray(r[0].solves, dtype=float)
        ds["solve_pressure"] = ("solve", s[:, 0], {"units": PRESSURE_UNITS,
                                                   "long_name": "pressure of each contact solve"})
        ds["solve_area_fraction"] = ("solve", s[:, 1], {
            "units": DIMENSIONLESS, "long_name": "contact area of each contact solve"})
        ds["solve_iterations"] = ("solve", s[:, 2].astype(np.int64), {
            "units": DIMENSIONLESS, "long_name": "solver iterations of each contact solve"})
        ds["solve_residual"] = ("solve", s[:, 3], {
            "units": DIMENSIONLESS,
            "long_name": "residual of each contact solve (gap error / rms height)"})
        ds["solve_scout"] = ("solve", s[:, 4].astype(np.int8), {
            "units": DIMENSIONLESS, **flags("full scout", np.int8),
            "long_name": "1 where the solve was a scout, solved to SCOUT_TOL_FACTOR times the "
                         "contact tolerance (docs/percolation.md), 0 where to the contact "
                         "tolerance itself"})
    return ds


def flow_dataset(results: Mapping[int | str, FlowResult], contact: np.ndarray, *, lx: float,
                 ly: float, eta: float, tol: float,
                 sigma_tol: float | None = None) -> xr.Dataset:
    """sigma per axis, the pressure and flux fields, and the solver diagnostics (the
    attribute ``sigma_tol`` only where the solves had one).

    ``results`` maps an axis (0 or ``"x"``, 1 or ``"y"``) to the
    :class:`~roughflow.flow.FlowResult` along it; a key that is not the result's own
    ``axis``, an ``lx`` / ``ly`` other than the result's, or a result on another grid than
    ``contact`` raises :class:`InputError`. ``eta`` and ``tol`` are recorded as given (a
    FlowResult does not carry them): pass those of the solves."""
    by_axis = _by_axis("flow_dataset", results, "FlowResult")
    nx, ny = np.shape(contact)
    for ax, r in by_axis.items():
        a = AXIS_NAMES[ax]
        for name, given, own in (("lx", lx, r.lx), ("ly", ly, r.ly)):
            if not np.isclose(float(given), float(own), rtol=1e-12, atol=0.0):
                raise InputError(f"flow_dataset: {name}={given!r} but the flow result along "
                                 f"{a} was solved with {name}={own!r}")
        if np.shape(r.pressure) != (nx, ny):
            raise InputError(f"flow_dataset: the flow result along {a} is on a "
                             f"{np.shape(r.pressure)} grid, the contact mask {(nx, ny)}")
    out = xr.Dataset(coords=grid_coords(nx, ny, lx, ly))
    out["contact"] = (("x", "y"), np.asarray(contact).astype(np.int8),
                      {"units": DIMENSIONLESS, "long_name": "contact mask (1 = contact)",
                       **CONTACT_FLAGS})
    attrs = {"title": "roughflow flow", "lx": lx, "ly": ly, "eta": eta, "tol": tol,
             **({} if sigma_tol is None else {"sigma_tol": sigma_tol})}
    for ax, r in sorted(by_axis.items()):
        a = AXIS_NAMES[ax]
        out[f"sigma_{a}"] = ((), r.sigma, {
            "units": SIGMA_UNITS,
            "long_name": f"effective conductance along {a}, Q L_{a} / (L_across dp) (Eq. 4)"})
        out[f"pressure_{a}"] = (("x", "y"), r.pressure, {
            "units": FLUID_PRESSURE_UNITS,
            "long_name": f"fluid pressure for flow along {a} as a fraction of the pressure drop "
                         "(inlet 1, outlet 0); NaN where no flow"})
        for comp, field in (("x", r.flux_x), ("y", r.flux_y)):
            out[f"flux_{comp}_{a}"] = (("x", "y"), field, {
                "units": FLUX_UNITS,
                "long_name": f"{comp} component of the flux density for flow along {a}"})
        attrs.update({f"sigma_{a}": r.sigma, f"residual_{a}": r.residual,
                      f"flux_imbalance_{a}": r.flux_imbalance, f"iterations_{a}": r.iterations,
                      f"percolating_{a}": r.percolating, f"method_{a}": r.method,
                      f"sigma_flux_{a}": r.sigma_flux, f"sigma_error_{a}": r.sigma_error,
                      f"imbalance_floor_{a}": r.imbalance_floor,
                      f"lumped_cells_{a}": r.lumped_cells})
    out.attrs = attrs
    return out


def persson_dataset(prediction: PerssonPrediction, source: SurfaceSpec | Surface, *,
                    eta: float = 1.0, energy_factor: float | None = None,
                    description: str = "") -> xr.Dataset:
    """The Persson prediction sigma(p) (:func:`roughflow.theory.predict_conductance`) over
    ``pressure``: a_c, mean gap and the closed-form sigma (Eq. 16), with the spec, or the
    surface (its spec, or its scan and reference length), it was computed from; ``eta`` and
    ``energy_factor``: those of the prediction (None: the default); ``description``: where
    the spectrum came from (the ``source`` attribute)."""
    factor = PERSSON_ENERGY_FACTOR if energy_factor is None else energy_factor
    p_attrs = {"units": PRESSURE_UNITS, "long_name": "applied mean pressure"}
    kind = prediction.kind
    ds = xr.Dataset(
        {
            "area_fraction": ("pressure", prediction.area_fraction, {
                "units": DIMENSIONLESS,
                "long_name": "Persson relative contact area erf(sqrt(2) p/(E* gbar))"}),
            "mean_gap": ("pressure", prediction.mean_gap, {
                "units": LENGTH_UNITS, "long_name": "Persson mean gap (Yang & Persson 2008)"}),
            "sigma": ("pressure", prediction.sigma, {
                "units": SIGMA_UNITS, "long_name": f"closed-form conductance, Eq. 16 ({kind})"}),
        },
        coords={"pressure": ("pressure", prediction.pressure, p_attrs)},
        attrs={
            "title": "roughflow theory: Persson prediction", "source": description,
            "kind": kind, "a_c_star": prediction.a_c_star, "eta": eta,
            "energy_factor": factor,
        },
    )
    ds.attrs.update(spec_attrs(source))
    return ds
