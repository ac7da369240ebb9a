"""Ladder scene: contact along an area ladder, Reynolds flow along x and y, theory lines.

Per seed: surface -> contact at increasing load (warm starts; the bearing model sets the
area directly and never solves elasticity) -> ``roughflow.flow.solve`` along each axis
where the fluid percolates (a non-percolating direction has sigma = 0 and is not solved)
-> Bruggeman (isotropic Eq. 5-6, anisotropic Eq. 7-9 in both forms) and the closed forms
of Eq. 16 from the same gap field. ``sigma_ref`` is the full Reynolds conductance at
a_c -> 0+ (the undeformed gap max(h) - h), the paper's normalisation.
"""

from __future__ import annotations

import logging
import math
import time

import numpy as np
import xarray as xr
from scipy.special import erfinv

from roughflow.accuracy import PERIMETER_C, perimeter_corrected_area
from roughflow.contact import DEFAULT_TOL
from roughflow.errors import InputError
from roughflow.surface import Surface, generate

from ._data import AXIS_COORD, no_fill_on_coords, param_coords, surface_vars, var
from .jobs import LadderJob

log = logging.getLogger(__name__)

EMT_FORMS = ("isotropic", "isotropic_alt", "anisotropic_corrected", "anisotropic_persson")
# a(p) ~ erf(kappa p): Persson theory has kappa = sqrt(2); simulations give a ~25 % larger
# small-load slope (physics.md 6), the initial guess of the pressure ladder.
KAPPA0 = 1.77
# the paper's adhesive case needs about 1/8 of the load for the same area: 8x the slope
ADHESIVE_SLOPE_FACTOR = 8.0
SIGMA_UNITS = "L^3 / eta (gap^3 / (12 eta) units, E* = gbar = L = eta = 1)"


class PressureLadder:
    """Next load for a target area: linear extrapolation of z = erfinv(a) in p."""

    def __init__(self, model: str):
        self.points: list[tuple[float, float]] = []
        self.model = model

    def add(self, p: float, a: float) -> None:
        self.points.append((p, float(erfinv(min(max(a, 1e-9), 0.999)))))

    def next(self, target: float) -> float:
        z = float(erfinv(target))
        slope0 = KAPPA0 * (ADHESIVE_SLOPE_FACTOR if self.model == "adhesive" else 1.0)
        if not self.points:
            return z / slope0
        p1, z1 = self.points[-1]
        if len(self.points) == 1:
            if self.model == "elastic" and z1 > 0 and p1 > 0:
                p = p1 * z / z1
            else:
                p = p1 + (z - z1) / slope0
        else:
            p0, z0 = self.points[-2]
            slope = (z1 - z0) / (p1 - p0) if p1 != p0 else slope0
            slope = slope if slope > 0 else slope0
            p = p1 + (z - z1) / slope
        return max(p, p1 * 1.02 if p1 > 0 else p1 + 1e-3)


def _adhesion(surface: Surface, job: LadderJob, lambda_s: float):
    """The job's adhesion on this surface: gamma_s = ratio x v_ela^full of the surface, and
    rho = range_over_lambda_s x lambda_s (or from the Tabor parameter)."""
    from roughflow.contact.adhesion import adhesion_for

    rho = None if job.range_over_lambda_s is None else job.range_over_lambda_s * lambda_s
    return adhesion_for(surface.heights, surface.lx, surface.ly, tabor=job.tabor, range=rho,
                        gamma_over_v_full=job.surface_energy_ratio)


def _adhesion_attrs(surface: Surface, adhesion, lambda_s: float, job: LadderJob) -> dict:
    """Dataset attributes of the adhesion (of the job's first seed)."""
    from roughflow.contact.adhesion import tabor_parameter

    return {"surface_energy_ratio": job.surface_energy_ratio,
            "range_over_lambda_s": adhesion.range / lambda_s,
            "tabor": tabor_parameter(surface.heights, surface.lx, surface.ly, adhesion),
            "adhesion_surface_energy": adhesion.surface_energy,
            "adhesion_range": adhesion.range, "adhesion_repulsion": adhesion.repulsion}


def _contact_ladder(surface: Surface, job: LadderJob, threads: int | None, adhesion=None):
    """Yield (target, ContactResult, corrected area) along the job's area ladder.

    The targets are met in the perimeter-corrected area for the elastic model (the
    continuum estimate, :func:`_corrected_area`), in the cell count otherwise."""
    from roughflow import contact

    lx, ly = surface.lx, surface.ly
    kw = {} if threads is None else {"threads": threads}
    if job.model == "bearing":
        for a in job.area_fractions:
            res = contact.solve(surface, model="bearing", area_fraction=a)
            yield a, res, _corrected_area(res, job.model, lx, ly)
        return
    if adhesion is not None:
        kw["adhesion"] = adhesion
    ladder = PressureLadder(job.model)
    prev = None
    for a in job.area_fractions:
        p = ladder.next(a)
        if job.model == "elastic" and p <= 0:
            p = 1e-6
        res = contact.solve(surface, p, model=job.model, init=prev, **kw)
        if p > 0 and res.area_fraction == 0:
            log.warning("%s contact at p = %.4g has no contact at all (%d iterations): check "
                        "the contact solver", job.model, p, res.iterations)
        a_cont = _corrected_area(res, job.model, lx, ly)
        ladder.add(res.pressure, res.area_fraction if math.isnan(a_cont) else a_cont)
        prev = res
        yield a, res, a_cont


def _theory(gap: np.ndarray, contact: np.ndarray, a_c: float, mean_gap: float,
            job: LadderJob) -> dict:
    """Bruggeman (all forms; 0 beyond their a_c*) and the closed form for one gap field.

    ``a_c`` is the continuum estimate of the contact area (perimeter-corrected for the
    elastic model). The Bruggeman sums run over the grid cells, whose contact fraction
    exceeds ``a_c`` by the grid bias; their thresholds are shifted by the same bias, so that
    the theory's a_c* refers to the continuum area like the closed form's and the plot's
    abscissa (without the shift the full Bruggeman line would vanish at a raw 0.4, a
    continuum 0.34 at 2 points per lambda_s)."""
    from roughflow import theory

    shift = max(float(np.mean(contact)) - a_c, 0.0)

    def on_grid(a_c_star: float) -> float:
        return min(a_c_star + shift, 0.999)

    s = theory.local_conductivity(gap, contact=contact).ravel()
    out = {"sigma_emt": np.full((len(EMT_FORMS), 2), np.nan), "gamma_tilde": np.nan}
    iso = theory.bruggeman(s, a_c_star=on_grid(job.a_c_star))
    out["sigma_emt"][0] = iso.sigma
    out["emt_residual"] = float(iso.residual)
    if job.a_c_star_alt is not None:
        out["sigma_emt"][1] = theory.bruggeman(s, a_c_star=on_grid(job.a_c_star_alt)).sigma
    for k, form in ((2, "corrected"), (3, "persson")):
        r = theory.bruggeman_anisotropic(s, a_c_star=on_grid(job.a_c_star),
                                         gamma=job.surface.gamma, form=form)
        out["sigma_emt"][k] = (r.sigma_x, r.sigma_y)
        if form == "corrected":
            out["gamma_tilde"] = float(r.gamma_tilde)
    cf = theory.closed_form(mean_gap, a_c, a_c_star=job.a_c_star, kind=job.model)
    out["sigma_closed_form"] = float(np.asarray(cf))
    return out


def _corrected_area(c, model: str, lx: float, ly: float) -> float:
    """Perimeter-corrected contact area of one ladder state (see the variable's long_name)."""
    if model == "elastic":
        return perimeter_corrected_area(c.contact, lx, ly)
    return float(c.area_fraction) if model == "bearing" else math.nan


def run_ladder(job: LadderJob, *, threads: int | None = None) -> xr.Dataset:
    """Dataset over (seed, step[, axis]) for the job's area ladder."""
    from roughflow import flow, percolation

    if list(job.area_fractions) != sorted(job.area_fractions):
        raise InputError(f"area_fractions must increase, got {job.area_fractions}")
    p = job.surface
    ns, nk = len(job.seeds), len(job.area_fractions)
    nan2 = np.full((ns, nk), np.nan)
    r = {k: nan2.copy() for k in ("area_fraction", "area_fraction_corrected", "pressure",
                                  "mean_gap", "contact_residual",
                                  "sigma_closed_form", "gamma_tilde", "emt_residual")}
    r["contact_iterations"] = np.full((ns, nk), -1, dtype=np.int64)
    r["sigma"] = np.full((ns, nk, 2), np.nan)
    r["flow_residual"] = np.full((ns, nk, 2), np.nan)
    r["flow_iterations"] = np.full((ns, nk, 2), -1, dtype=np.int64)
    r["percolating"] = np.full((ns, nk, 2), -1, dtype=np.int64)
    r["sigma_emt"] = np.full((ns, nk, len(EMT_FORMS), 2), np.nan)
    r["sigma_ref"] = np.full((ns, 2), np.nan)
    r["wall_time"] = np.zeros(ns)
    adhesion_attrs = {}
    for i, seed in enumerate(job.seeds):
        t0 = time.perf_counter()
        spec = p.spec(seed)
        surface = generate(spec)
        lx, ly = surface.lx, surface.ly
        log.info("seed %d: %s model, %d x %d grid, gamma=%g H=%g L/lambda_r=%g eps_f=%g",
                 seed, job.model, spec.nx, spec.ny, p.gamma, p.hurst, p.size, p.eps_f)
        gap0 = surface.heights.max() - surface.heights
        r["sigma_ref"][i] = flow.conductance(gap0, None, lx=lx, ly=ly)
        log.info("seed %d: sigma_ref = (%.4g, %.4g)", seed, *r["sigma_ref"][i])
        adhesion = _adhesion(surface, job, spec.lambda_s) if job.model == "adhesive" else None
        if adhesion is not None:
            log.info("adhesion: surface energy %.4g, range %.4g", adhesion.surface_energy,
                     adhesion.range)
            if i == 0:
                adhesion_attrs = _adhesion_attrs(surface, adhesion, spec.lambda_s, job)
        for k, (target, c, a_cont) in enumerate(
                _contact_ladder(surface, job, threads, adhesion)):
            r["area_fraction"][i, k] = c.area_fraction
            r["area_fraction_corrected"][i, k] = a_cont
            r["pressure"][i, k] = c.pressure
            r["mean_gap"][i, k] = c.mean_gap
            r["contact_residual"][i, k] = c.residual
            r["contact_iterations"][i, k] = c.iterations
            open_mask = ~np.asarray(c.contact, dtype=bool)
            for ax in (0, 1):
                perc = bool(percolation.percolates(open_mask, ax))
                r["percolating"][i, k, ax] = int(perc)
                if not perc:  # not solved: no fluid path, sigma = 0 exactly
                    r["sigma"][i, k, ax] = 0.0
                    r["flow_iterations"][i, k, ax] = 0
                    r["flow_residual"][i, k, ax] = 0.0
                    continue
                fr = flow.solve(c.gap, ax, lx=lx, ly=ly)
                r["sigma"][i, k, ax] = fr.sigma
                r["flow_residual"][i, k, ax] = fr.residual
                r["flow_iterations"][i, k, ax] = fr.iterations
            th = _theory(c.gap, ~open_mask, c.area_fraction if math.isnan(a_cont) else a_cont,
                         c.mean_gap, job)
            r["sigma_emt"][i, k] = th["sigma_emt"]
            for name in ("sigma_closed_form", "gamma_tilde", "emt_residual"):
                r[name][i, k] = th[name]
            log.info("seed %d step %d: target a_c %.3f -> a_c %.4f at p %.4g (%d iterations), "
                     "sigma = (%.3g, %.3g), Bruggeman %.3g, closed form %.3g", seed, k, target,
                     c.area_fraction, c.pressure, c.iterations, *r["sigma"][i, k],
                     th["sigma_emt"][0, 0], th["sigma_closed_form"])
        r["wall_time"][i] = time.perf_counter() - t0
        log.info("seed %d done in %.1f s", seed, r["wall_time"][i])
    sk, ska = ("seed", "step"), ("seed", "step", "axis")
    data = {
        "area_fraction": var(r["area_fraction"], sk, "1", "relative contact area a_c"),
        "area_fraction_corrected": var(
            r["area_fraction_corrected"], sk, "1",
            "a_c with the perimeter correction (elastic: first-order grid bias removed, "
            "docs/accuracy.md; bearing: = a_c, unbiased; adhesive: NaN, not calibrated)"),
        "target_area_fraction": var(np.broadcast_to(job.area_fractions, (ns, nk)), sk, "1",
                                    "target of the area ladder"),
        "pressure": var(r["pressure"], sk, "E* gbar", "applied mean pressure"),
        "mean_gap": var(r["mean_gap"], sk, "L", "mean gap u_g"),
        "contact_residual": var(r["contact_residual"], sk, "rms height",
                                "residual of the contact solve"),
        "contact_iterations": var(r["contact_iterations"], sk, "1",
                                  "iterations of the contact solve"),
        "sigma": var(r["sigma"], ska, SIGMA_UNITS, "full Reynolds conductance sigma"),
        "percolating": var(r["percolating"], ska, "1", "fluid percolates along axis (1/0)"),
        "flow_residual": var(r["flow_residual"], ska, "1", "relative residual of the flow solve"),
        "flow_iterations": var(r["flow_iterations"], ska, "1", "iterations of the flow solve"),
        "sigma_emt": var(r["sigma_emt"], ("seed", "step", "emt", "axis"), SIGMA_UNITS,
                         "Bruggeman effective-medium conductance"),
        "sigma_closed_form": var(r["sigma_closed_form"], sk, SIGMA_UNITS,
                                 "closed-form conductance, Eq. 16"),
        "gamma_tilde": var(r["gamma_tilde"], sk, "1",
                           "self-consistent gamma~ of the corrected anisotropic Bruggeman"),
        "emt_residual": var(r["emt_residual"], sk, "1", "residual of the isotropic Bruggeman"),
        "sigma_ref": var(r["sigma_ref"], ("seed", "axis"), SIGMA_UNITS,
                         "full Reynolds conductance at a_c -> 0+ (gap max(h) - h)"),
        "wall_time": var(r["wall_time"], ("seed",), "s", "wall time of the seed's ladder"),
    }
    data.update(surface_vars(p, job.seeds[0]))
    coords = param_coords(p, job.model)
    coords["seed"] = ("seed", np.asarray(job.seeds, dtype=np.int64), {"long_name": "surface seed"})
    coords["step"] = ("step", np.arange(nk), {"long_name": "index on the area ladder"})
    coords["axis"] = AXIS_COORD
    coords["emt"] = ("emt", list(EMT_FORMS), {"long_name": "effective-medium form"})
    a_alt = job.a_c_star_alt if job.a_c_star_alt is not None else math.nan
    ds = xr.Dataset(data, coords=coords, attrs={
        "title": "roughflow ladder scene", "scene": "ladder", "job_id": job.job_id,
        "error_budget_points_per_lambda_s": p.points_per_lambda_s,
        "error_budget_contact_tol": DEFAULT_TOL, "error_budget_perimeter_c": PERIMETER_C,
        "a_c_star_theory": job.a_c_star, "a_c_star_alt": a_alt,
        "emt_forms": "isotropic: Eq. 5-6 with a_c_star_theory; isotropic_alt: the same with "
                     "a_c_star_alt; anisotropic_corrected: Eq. 9; anisotropic_persson: Eq. 7-8",
    })
    ds.attrs.update(adhesion_attrs)
    return no_fill_on_coords(ds)
