"""Threshold scene: percolation thresholds a_c*(x), a_c*(y) for a group of seeds.

Surface -> ``roughflow.percolation.threshold(surface, axis=None, model=...)`` per seed
(contact bisection in pressure for the elastic model, one height-ordered pass for the
bearing model); never a flow solve.
"""

from __future__ import annotations

import logging
import time

import numpy as np
import xarray as xr

from roughflow.accuracy import PERIMETER_C
from roughflow.surface import generate

from ._data import AXIS_COORD, no_fill_on_coords, param_coords, surface_vars, var
from .jobs import ThresholdJob

log = logging.getLogger(__name__)

FIELDS = {
    # name: (units, long_name, dtype)
    "a_c_star": ("1", "percolation threshold a_c* (relative contact area)", float),
    "a_c_star_corrected": ("1", "a_c* with the perimeter correction of the contact area "
                           "(first-order grid bias removed; elastic model)", float),
    "a_lo": ("1", "largest contact area at which the fluid still percolates", float),
    "a_hi": ("1", "smallest contact area at which the fluid no longer percolates", float),
    "p_lo": ("E* gbar", "pressure of a_lo", float),
    "p_hi": ("E* gbar", "pressure of a_hi", float),
    "n_solves": ("1", "contact solves used by the bisection", int),
}


def _per_axis(result, axis: int):
    """Pick one axis from ``threshold(..., axis=None)`` (mapping or sequence)."""
    if isinstance(result, dict):
        for key in (axis, "xy"[axis]):
            if key in result:
                return result[key]
        raise KeyError(f"threshold result has no entry for axis {axis}: {list(result)}")
    return result[axis]


def run_threshold(job: ThresholdJob, *, threads: int | None = None) -> xr.Dataset:
    """Dataset with a_c*(seed, axis) and its bracket, one entry per seed of ``job``."""
    from roughflow.percolation import threshold

    p = job.surface
    values = {k: np.full((len(job.seeds), 2), np.nan) for k in FIELDS}
    values["n_solves"] = np.full((len(job.seeds), 2), -1, dtype=np.int64)
    seconds = np.zeros(len(job.seeds))
    residual = np.zeros(len(job.seeds))
    for i, seed in enumerate(job.seeds):
        t0 = time.perf_counter()
        spec = p.spec(seed)
        surface = generate(spec)
        log.info("seed %d: %s model, %d x %d grid, gamma=%g H=%g L/lambda_r=%g eps_f=%g",
                 seed, job.model, spec.nx, spec.ny, p.gamma, p.hurst, p.size, p.eps_f)
        res = threshold(surface, axis=None, model=job.model, tol=job.tol, threads=threads,
                        contact_tol=job.contact_tol, on_unbracketed="nan")
        for k, step in enumerate(getattr(_per_axis(res, 0), "solves", ()) or ()):
            log.info("seed %d bisection step %d: %s", seed, k + 1,
                     ", ".join(f"{n} {v:.5g}" for n, v in zip(
                         ("p", "a_c", "iterations", "residual"), step, strict=False)))
            residual[i] = max(residual[i], float(step[3]))
        for ax in (0, 1):
            r = _per_axis(res, ax)
            if not getattr(r, "bracketed", True):
                log.warning("seed %d axis %s: threshold not bracketed (%s); stored as NaN",
                            seed, "xy"[ax], getattr(r, "message", ""))
            for k in FIELDS:
                values[k][i, ax] = getattr(r, k)
            log.info("seed %d axis %s: a_c* = %.4f in [%.4f, %.4f], %d solves", seed, "xy"[ax],
                     r.a_c_star, r.a_lo, r.a_hi, r.n_solves)
        seconds[i] = time.perf_counter() - t0
        log.info("seed %d done in %.1f s", seed, seconds[i])
    data = {k: var(values[k], ("seed", "axis"), u, n) for k, (u, n, _) in FIELDS.items()}
    data["wall_time"] = var(seconds, ("seed",), "s", "wall time of the seed's bisection")
    data["contact_residual"] = var(residual, ("seed",), "1",
                                   "largest residual of the seed's contact solves "
                                   "(gap error / rms height)")
    data.update(surface_vars(p, job.seeds[0]))
    coords = param_coords(p, job.model)
    coords["seed"] = ("seed", np.asarray(job.seeds, dtype=np.int64), {"long_name": "surface seed"})
    coords["axis"] = AXIS_COORD
    ds = xr.Dataset(data, coords=coords, attrs={
        "title": "roughflow threshold scene", "scene": "threshold", "tol": job.tol,
        "job_id": job.job_id, "error_budget_points_per_lambda_s": p.points_per_lambda_s,
        "error_budget_bisection_tol": job.tol, "error_budget_contact_tol": job.contact_tol,
        "error_budget_perimeter_c": PERIMETER_C,
    })
    return no_fill_on_coords(ds)
