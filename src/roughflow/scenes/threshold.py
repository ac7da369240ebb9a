"""Threshold scene: percolation thresholds a_c*(x), a_c*(y) for a group of seeds.

Surface -> :func:`roughflow.search.threshold` per seed (warm-started contact solves for the
elastic model, one height-ordered pass for the bearing model); never a flow solve.
"""

from __future__ import annotations

import logging
import time

import numpy as np
import xarray as xr

from roughflow.accuracy import PERIMETER_C
from roughflow.datasets import threshold_dataset
from roughflow.datasets.sweep import (
    no_fill_on_coords,
    param_coords,
    seed_coord,
    surface_vars,
    var,
)
from roughflow.datasets.units import RESIDUAL_UNITS, SECONDS
from roughflow.defaults import AXIS_NAMES
from roughflow.search import SearchOptions, threshold
from roughflow.surface import generate

from .jobs import ThresholdJob

log = logging.getLogger(__name__)


def run_threshold(job: ThresholdJob, *, threads: int | None = None) -> xr.Dataset:
    """Dataset with a_c*(seed, axis) and its bracket, one entry per seed of ``job``."""
    p = job.surface
    per_seed = []
    seconds = np.zeros(len(job.seeds))
    residual = np.zeros(len(job.seeds))
    options = SearchOptions(contact_tol=job.contact_tol, on_unbracketed="nan")
    for i, seed in enumerate(job.seeds):
        t0 = time.perf_counter()
        spec = p.spec(seed)
        surface = generate(spec)
        log.info("seed %d: %s model, %d x %d grid, gamma=%g H=%g L/lambda_r=%g eps_f=%g",
                 seed, job.model, spec.nx, spec.ny, p.gamma, p.hurst, p.size, p.eps_f)
        res = threshold(surface, axis=None, model=job.model, tol=job.tol, options=options,
                        threads=threads)
        # scouts stop at SCOUT_TOL_FACTOR times the contact tolerance by design; the
        # solves that end the brackets are all full ones
        residual[i] = max((s.residual for s in res[0].solves if not s.scout), default=0.0)
        for ax, r in res.items():
            if not r.bracketed:
                log.warning("seed %d axis %s: threshold not bracketed (%s); stored as NaN",
                            seed, AXIS_NAMES[ax], r.message)
            log.info("seed %d axis %s: a_c* = %.4f in [%.4f, %.4f], %d solves", seed,
                     AXIS_NAMES[ax], r.a_c_star, r.a_lo, r.a_hi, r.n_solves)
        per_seed.append(threshold_dataset(res, solve_log=False))
        seconds[i] = time.perf_counter() - t0
        log.info("seed %d done in %.1f s", seed, seconds[i])
    stacked = xr.concat(per_seed, dim="seed")
    data = {}
    for name, v in stacked.data_vars.items():
        values = v.transpose("seed", "axis").values
        data[name] = var(values, ("seed", "axis"), **v.attrs)
    data["wall_time"] = var(seconds, ("seed",), SECONDS, "wall time of the seed's search")
    data["contact_residual"] = var(residual, ("seed",), RESIDUAL_UNITS,
                                   "largest residual of the seed's contact solves to the "
                                   "contact tolerance (scouts, solved to a looser one by "
                                   "design, left out)")
    data.update(surface_vars(p, job.seeds[0]))
    coords = param_coords(p, job.model)
    coords["seed"] = seed_coord(job.seeds)
    coords["axis"] = ("axis", stacked["axis"].values, stacked["axis"].attrs)
    ds = xr.Dataset(data, coords=coords, attrs={
        "title": "roughflow threshold scene", "scene": "threshold", "tol": job.tol,
        "job_id": job.job_id, "error_budget_points_per_lambda_s": p.points_per_lambda_s,
        "error_budget_threshold_tol": job.tol, "error_budget_contact_tol": job.contact_tol,
        "error_budget_perimeter_c": PERIMETER_C,
    })
    return no_fill_on_coords(ds)
