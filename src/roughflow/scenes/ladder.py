"""Ladder scene: contact along an area ladder, Reynolds flow along x and y, theory lines.

Per seed: surface -> contact at each target area (a load search with warm starts,
:class:`roughflow.search.LoadSearch`, to within the job's ``area_tol``; the bearing model
sets the area directly and never solves elasticity) -> ``roughflow.flow.solve`` along each
axis where the fluid percolates (a non-percolating direction has sigma = 0 and is not
solved) -> Bruggeman (isotropic Eq. 5-6, anisotropic Eq. 7-9 in both forms) and the closed
forms of Eq. 16 from the same gap field (:func:`roughflow.theory.gap_theory`).
``sigma_ref`` is the full Reynolds conductance at a_c -> 0+ (the undeformed gap
max(h) - h), the paper's normalisation.
"""

from __future__ import annotations

import logging
import math
import time
from typing import TYPE_CHECKING

import numpy as np
import xarray as xr

from roughflow import contact, flow, theory
from roughflow.accuracy import PERIMETER_C, perimeter_corrected_area
from roughflow.datasets.results import (
    ADHESION_FIELDS,
    ADHESION_REPULSION_FIELD,
    AXIS_COORD,
    FLOW_IMBALANCE_FLOOR_LONG_NAME,
    FLOW_IMBALANCE_LONG_NAME,
    FLOW_SIGMA_ERROR_LONG_NAME,
    adhesion_attrs,
)
from roughflow.datasets.sweep import (
    no_fill_on_coords,
    param_coords,
    seed_coord,
    surface_vars,
    var,
)
from roughflow.datasets.units import (
    DIMENSIONLESS,
    LENGTH_UNITS,
    PRESSURE_UNITS,
    RESIDUAL_UNITS,
    SECONDS,
    SIGMA_UNITS,
    flags,
)
from roughflow.defaults import CONTACT_TOL, FLOW_SIGMA_TOL
from roughflow.errors import ConvergenceError
from roughflow.search import LoadSearch, warm_start_compliance
from roughflow.surface import Surface, generate

from .jobs import LadderJob

if TYPE_CHECKING:
    from collections.abc import Iterator

log = logging.getLogger(__name__)

EMT_FORMS = ("isotropic", "isotropic_alt", "anisotropic_corrected", "anisotropic_persson")


def _adhesion(surface: Surface, job: LadderJob, lambda_s: float):
    """The job's adhesion on this surface: gamma_s = ratio x v_ela^full of the surface, and
    rho = range_over_lambda_s x lambda_s (or from the Tabor parameter)."""
    from roughflow.contact.adhesion import adhesion_for

    rho = None if job.range_over_lambda_s is None else job.range_over_lambda_s * lambda_s
    return adhesion_for(surface.heights, surface.lx, surface.ly, tabor=job.tabor, range=rho,
                        gamma_over_v_full=job.surface_energy_ratio, repulsion=job.repulsion)


def _adhesion_numbers(surface: Surface, adhesion, lambda_s: float) -> dict:
    """The adhesion on one seed's surface (:data:`ADHESION_FIELDS`): a contact result's
    attributes, and the range in units of lambda_s."""
    return {**adhesion_attrs(surface, adhesion),
            "adhesion_range_over_lambda_s": adhesion.range / lambda_s}


def contact_ladder(surface: Surface, job: LadderJob, threads: int | None,
                   adhesion: contact.Adhesion | None = None,
                   ) -> Iterator[tuple[float, contact.ContactResult, float]]:
    """Yield (target, ContactResult, corrected area) along the job's area ladder.

    The targets are met in the perimeter-corrected area for the elastic model (the
    continuum estimate, :func:`_corrected_area`), in the cell count otherwise. The adhesive
    model uses ``adhesion``, or the job's own on this surface when None."""
    if job.model == "bearing":
        for a in job.area_fractions:
            res = contact.solve(surface, model="bearing", area_fraction=a)
            yield a, res, _corrected_area(res, job.model)
        return
    kw = {"model": job.model, "threads": threads}
    if job.model == "adhesive":
        kw["adhesion"] = (_adhesion(surface, job, surface.spec.lambda_s) if adhesion is None
                          else adhesion)
    if job.model == "elastic":  # built once for all solves of the ladder
        kw["setup"] = contact.prepare(surface, threads)

    def solve(p: float, init):
        return contact.solve(surface, p, init=init, **kw)

    def measure(r) -> float:
        a = _corrected_area(r, job.model)
        return float(r.area_fraction) if math.isnan(a) else a

    search = LoadSearch(solve, contact.ContactLaw(job.model), measure=measure,
                        compliance=warm_start_compliance(surface, job.model))
    for a in job.area_fractions:
        found = search.solve_for(a, job.area_tol)
        if not found.met:
            log.warning("target a_c %.4g missed: closest %.5g after %d solves", a, found.area,
                        found.solves)
        yield a, found.result, _corrected_area(found.result, job.model)


def _theory(gap: np.ndarray, contact_mask: np.ndarray, a_c: float,
            job: LadderJob) -> theory.GapTheory:
    """Bruggeman (all forms; 0 beyond their a_c*) and the closed form for one gap field;
    ``a_c`` is the continuum estimate of the contact area (perimeter-corrected for the
    elastic model), to which the thresholds refer (:func:`roughflow.theory.gap_theory`)."""
    return theory.gap_theory(gap, contact=contact_mask, a_c_star=job.a_c_star,
                             gamma=job.surface.gamma, kind=job.model, area_fraction=a_c,
                             a_c_star_alt=job.a_c_star_alt)


def _corrected_area(c, model: str) -> float:
    """Perimeter-corrected contact area of one ladder state (see the variable's long_name)."""
    if model == "elastic":
        return perimeter_corrected_area(c.contact)
    return float(c.area_fraction) if model == "bearing" else math.nan


def run_ladder(job: LadderJob, *, threads: int | None = None) -> xr.Dataset:
    """Dataset over (seed, step[, axis]) for the job's area ladder."""
    p = job.surface
    ns, nk = len(job.seeds), len(job.area_fractions)
    nan2 = np.full((ns, nk), np.nan)
    r = {k: nan2.copy() for k in ("area_fraction", "area_fraction_corrected", "pressure",
                                  "mean_gap", "contact_residual",
                                  "sigma_closed_form", "gamma_tilde", "emt_residual")}
    r["contact_iterations"] = np.full((ns, nk), -1, dtype=np.int64)
    r["sigma"] = np.full((ns, nk, 2), np.nan)
    r["flow_residual"] = np.full((ns, nk, 2), np.nan)
    r["flow_imbalance"] = np.full((ns, nk, 2), np.nan)
    r["flow_imbalance_floor"] = np.full((ns, nk, 2), np.nan)
    r["flow_sigma_error"] = np.full((ns, nk, 2), np.nan)
    r["flow_iterations"] = np.full((ns, nk, 2), -1, dtype=np.int64)
    r["flow_direct"] = np.full((ns, nk, 2), -1, dtype=np.int64)
    r["flow_lumped_cells"] = np.full((ns, nk, 2), -1, dtype=np.int64)
    r["percolating"] = np.full((ns, nk, 2), -1, dtype=np.int64)
    r["sigma_emt"] = np.full((ns, nk, len(EMT_FORMS), 2), np.nan)
    r["sigma_ref"] = np.full((ns, 2), np.nan)
    r["wall_time"] = np.zeros(ns)
    adhesion_seeds = {name: np.full(ns, np.nan) for name in ADHESION_FIELDS}
    repulsion = ""
    for i, seed in enumerate(job.seeds):
        t0 = time.perf_counter()
        spec = p.spec(seed)
        surface = generate(spec)
        lx, ly = surface.lx, surface.ly
        log.info("seed %d: %s model, %d x %d grid, gamma=%g H=%g L/lambda_r=%g eps_f=%g",
                 seed, job.model, spec.nx, spec.ny, p.gamma, p.hurst, p.size, p.eps_f)
        gap0 = surface.heights.max() - surface.heights
        r["sigma_ref"][i] = flow.conductance(gap0, None, lx=lx, ly=ly,
                                             sigma_tol=FLOW_SIGMA_TOL)
        log.info("seed %d: sigma_ref = (%.4g, %.4g)", seed, *r["sigma_ref"][i])
        adhesion = _adhesion(surface, job, spec.lambda_s) if job.model == "adhesive" else None
        if adhesion is not None:
            log.info("adhesion: surface energy %.4g, range %.4g", adhesion.surface_energy,
                     adhesion.range)
            numbers = _adhesion_numbers(surface, adhesion, spec.lambda_s)
            for name in ADHESION_FIELDS:
                adhesion_seeds[name][i] = numbers[name]
            repulsion = str(numbers[ADHESION_REPULSION_FIELD[0]])
        flows = None  # the last step's, whose orderings the next step's solves reuse
        for k, (target, c, a_cont) in enumerate(
                contact_ladder(surface, job, threads, adhesion)):
            r["area_fraction"][i, k] = c.area_fraction
            r["area_fraction_corrected"][i, k] = a_cont
            r["pressure"][i, k] = c.pressure
            r["mean_gap"][i, k] = c.mean_gap
            r["contact_residual"][i, k] = c.residual
            r["contact_iterations"][i, k] = c.iterations
            open_mask = ~np.asarray(c.contact, dtype=bool)
            try:
                flows = flow.flow_both_axes(c.gap, open_mask, lx=lx, ly=ly, previous=flows,
                                            sigma_tol=FLOW_SIGMA_TOL)
            except ConvergenceError as exc:  # the CLI saves the inputs that reproduce it
                exc.inputs = {**(exc.inputs or {}), "seed": seed, "target": target}
                raise
            for ax, f in enumerate(flows):
                r["percolating"][i, k, ax] = int(f.percolating)
                r["sigma"][i, k, ax] = f.sigma
                fr = f.result  # None: not solved, no fluid path, every diagnostic 0
                r["flow_residual"][i, k, ax] = 0.0 if fr is None else fr.residual
                r["flow_imbalance"][i, k, ax] = 0.0 if fr is None else fr.flux_imbalance
                r["flow_imbalance_floor"][i, k, ax] = 0.0 if fr is None else fr.imbalance_floor
                r["flow_sigma_error"][i, k, ax] = 0.0 if fr is None else fr.sigma_error
                r["flow_iterations"][i, k, ax] = 0 if fr is None else fr.iterations
                r["flow_direct"][i, k, ax] = int(fr is not None and fr.method == "direct")
                r["flow_lumped_cells"][i, k, ax] = 0 if fr is None else fr.lumped_cells
            th = _theory(c.gap, ~open_mask, c.area_fraction if math.isnan(a_cont) else a_cont,
                         job)
            r["sigma_emt"][i, k] = (
                (th.sigma_isotropic,) * 2, (th.sigma_alt,) * 2,
                (th.corrected.sigma_x, th.corrected.sigma_y),
                (th.persson.sigma_x, th.persson.sigma_y))
            r["sigma_closed_form"][i, k] = th.sigma_closed_form
            r["gamma_tilde"][i, k] = th.corrected.gamma_tilde
            r["emt_residual"][i, k] = th.isotropic_residual
            log.info("seed %d step %d: target a_c %.3f -> a_c %.4f at p %.4g (%d iterations), "
                     "sigma = (%.3g, %.3g), Bruggeman %.3g, closed form %.3g", seed, k, target,
                     c.area_fraction, c.pressure, c.iterations, *r["sigma"][i, k],
                     th.sigma_isotropic, th.sigma_closed_form)
        r["wall_time"][i] = time.perf_counter() - t0
        log.info("seed %d done in %.1f s", seed, r["wall_time"][i])
    sk, ska = ("seed", "step"), ("seed", "step", "axis")
    data = {
        "area_fraction": var(r["area_fraction"], sk, DIMENSIONLESS, "relative contact area a_c"),
        "area_fraction_corrected": var(
            r["area_fraction_corrected"], sk, DIMENSIONLESS,
            "a_c with the perimeter correction (elastic: first-order grid bias removed, "
            "docs/accuracy.md; bearing: = a_c, unbiased; adhesive: NaN, not calibrated)"),
        "target_area_fraction": var(np.broadcast_to(job.area_fractions, (ns, nk)), sk,
                                    DIMENSIONLESS, "target of the area ladder"),
        "pressure": var(r["pressure"], sk, PRESSURE_UNITS, "applied mean pressure"),
        "mean_gap": var(r["mean_gap"], sk, LENGTH_UNITS, "mean gap u_g"),
        "contact_residual": var(r["contact_residual"], sk, RESIDUAL_UNITS,
                                "residual of the contact solve"),
        "contact_iterations": var(r["contact_iterations"], sk, DIMENSIONLESS,
                                  "iterations of the contact solve"),
        "sigma": var(r["sigma"], ska, SIGMA_UNITS, "full Reynolds conductance sigma"),
        "percolating": var(r["percolating"], ska, DIMENSIONLESS,
                           "1 if the fluid percolates along axis", **flags("sealed leaking")),
        "flow_residual": var(r["flow_residual"], ska, DIMENSIONLESS,
                             "relative residual of the flow solve (0: not solved, the fluid "
                             "does not percolate)"),
        "flow_imbalance": var(r["flow_imbalance"], ska, DIMENSIONLESS, FLOW_IMBALANCE_LONG_NAME),
        "flow_imbalance_floor": var(r["flow_imbalance_floor"], ska, DIMENSIONLESS,
                                    FLOW_IMBALANCE_FLOOR_LONG_NAME),
        "flow_sigma_error": var(r["flow_sigma_error"], ska, DIMENSIONLESS,
                                FLOW_SIGMA_ERROR_LONG_NAME),
        "flow_iterations": var(r["flow_iterations"], ska, DIMENSIONLESS,
                               "iterations of the flow solve"),
        "flow_direct": var(r["flow_direct"], ska, DIMENSIONLESS,
                           "1 if the flow solve was the direct LDL^T solver (small systems, "
                           "thin flowing clusters, or the fallback of an AMG solve that did "
                           "not converge or balance the fluxes), 0: AMG-CG or no solve",
                           **flags("iterative_or_none direct")),
        "flow_lumped_cells": var(r["flow_lumped_cells"], ska, DIMENSIONLESS,
                                 "cells the flow solve lumped into near-equipotential "
                                 "regions (deep pockets float64 cannot resolve; 0: none)"),
        "sigma_emt": var(r["sigma_emt"], ("seed", "step", "emt", "axis"), SIGMA_UNITS,
                         "Bruggeman effective-medium conductance"),
        "sigma_closed_form": var(r["sigma_closed_form"], sk, SIGMA_UNITS,
                                 "closed-form conductance, Eq. 16"),
        "gamma_tilde": var(r["gamma_tilde"], sk, DIMENSIONLESS,
                           "self-consistent gamma~ of the corrected anisotropic Bruggeman"),
        "emt_residual": var(r["emt_residual"], sk, DIMENSIONLESS,
                            "residual of the isotropic Bruggeman"),
        "sigma_ref": var(r["sigma_ref"], ("seed", "axis"), SIGMA_UNITS,
                         "full Reynolds conductance at a_c -> 0+ (gap max(h) - h)"),
        "wall_time": var(r["wall_time"], ("seed",), SECONDS, "wall time of the seed's ladder"),
    }
    data.update(surface_vars(p, job.seeds[0]))
    a_alt = job.a_c_star_alt if job.a_c_star_alt is not None else math.nan
    # variables, not attributes: the models of a study differ in them (aggregate keeps an
    # attribute only where every job has it alike)
    data["a_c_star_theory"] = var(job.a_c_star, (), DIMENSIONLESS,
                                  "a_c* of the isotropic Bruggeman (Eq. 5-6) and the closed "
                                  "form (Eq. 16)")
    data["a_c_star_alt"] = var(a_alt, (), DIMENSIONLESS,
                               "second a_c* of the isotropic Bruggeman (emt isotropic_alt; "
                               "NaN: none)")
    if job.model == "adhesive":
        for name, (units, long_name) in ADHESION_FIELDS.items():
            data[name] = var(adhesion_seeds[name], ("seed",), units, long_name)
        data[ADHESION_REPULSION_FIELD[0]] = var(np.array(repulsion), (), DIMENSIONLESS,
                                                ADHESION_REPULSION_FIELD[1])
    coords = param_coords(p, job.model)
    coords["seed"] = seed_coord(job.seeds)
    coords["step"] = ("step", np.arange(nk), {"units": DIMENSIONLESS,
                                              "long_name": "index on the area ladder"})
    coords["axis"] = AXIS_COORD
    coords["emt"] = ("emt", list(EMT_FORMS), {"long_name": "effective-medium form"})
    ds = xr.Dataset(data, coords=coords, attrs={
        "title": "roughflow ladder scene", "scene": "ladder", "job_id": job.job_id,
        "error_budget_points_per_lambda_s": p.points_per_lambda_s,
        "error_budget_contact_tol": CONTACT_TOL, "error_budget_perimeter_c": PERIMETER_C,
        "error_budget_flow_sigma_tol": FLOW_SIGMA_TOL,
        "error_budget_area_tol": job.area_tol,
        "emt_forms": "isotropic: Eq. 5-6 with a_c_star_theory; isotropic_alt: the same with "
                     "a_c_star_alt; anisotropic_corrected: Eq. 9; anisotropic_persson: Eq. 7-8",
    })
    return no_fill_on_coords(ds)
