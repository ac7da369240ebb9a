"""Channels scene (paper Fig. 1): an isotropic 0.5 x 2 cell and its stretched square version.

Both cells have unit area and the same grid; with the same seed the gamma-stretched
square surface is exactly the isotropic rectangular one with x scaled by sqrt(gamma) and
y by 1/sqrt(gamma) (identical q_P on identical index grids), up to the rms-gradient
normalisation. Each is pressed to the target contact area (elastic: a load search,
:class:`roughflow.search.LoadSearch`; bearing: direct) and classified into contact, fluid
percolating along x (the cells of spanning clusters) and other fluid.
"""

from __future__ import annotations

import logging

import numpy as np
import xarray as xr

from roughflow import contact, defaults
from roughflow.datasets.units import DIMENSIONLESS, LENGTH_UNITS
from roughflow.percolation import contact_percolates, percolates, percolation_map
from roughflow.percolation.clusters import PHASE_NAMES
from roughflow.search import LoadSearch, warm_start_compliance
from roughflow.surface import Surface, generate

from .jobs import ChannelsJob

log = logging.getLogger(__name__)


def contact_at_area(surface: Surface, target: float, model: str, *,
                    tol: float = defaults.CHANNELS_AREA_TOL,
                    threads: int | None = None) -> contact.ContactResult:
    """Contact result whose area fraction is within ``tol`` of ``target`` (bearing: exact;
    elastic: :class:`roughflow.search.LoadSearch`; the closest solve if none is within)."""
    if model == "bearing":
        return contact.solve(surface, model="bearing", area_fraction=target)

    setup = contact.prepare(surface, threads) if model == "elastic" else None

    def solve(p: float, init):
        return contact.solve(surface, p, model=model, init=init, threads=threads, setup=setup)

    found = LoadSearch(solve, contact.ContactLaw(model),
                       compliance=warm_start_compliance(surface, model)).solve_for(target, tol)
    if not found.met:
        log.warning("target a_c %.4g missed: closest %.5g after %d solves", target,
                    found.area, found.solves)
    return found.result


def run_channels(job: ChannelsJob, *, threads: int | None = None) -> xr.Dataset:
    """Heights, gap and phase maps of both cells at the target contact area."""
    # every parameter of the job, not only inside job_parameters' command line
    data, attrs = {}, {"title": "roughflow channels scene (paper Fig. 1)", "scene": "channels",
                       "gamma": job.gamma, "hurst": job.hurst,
                       "l_over_lambda_r": job.l_over_lambda_r, "eps_f": job.eps_f,
                       "points_per_lambda_s": job.points_per_lambda_s,
                       "target_area_fraction": job.area_fraction,
                       "model": job.model, "seed": job.seed}
    for name, params in zip(("iso", "aniso"), job.surfaces(), strict=True):
        spec = params.spec(job.seed)
        surface = generate(spec)
        log.info("%s: %d x %d grid, %g x %g cell, gamma=%g", name, spec.nx, spec.ny,
                 spec.lx, spec.ly, spec.gamma)
        res = contact_at_area(surface, job.area_fraction, job.model, threads=threads)
        mask = np.asarray(res.contact, dtype=bool)
        phase = percolation_map(mask, 0)
        dims = (f"ix_{name}", f"iy_{name}")
        data[f"heights_{name}"] = (dims, surface.heights, {
            "units": LENGTH_UNITS, "long_name": f"height of the {name} surface"})
        data[f"gap_{name}"] = (dims, res.gap, {"units": LENGTH_UNITS,
                                              "long_name": f"gap of the {name} contact"})
        data[f"phase_{name}"] = (dims, phase, {
            "units": DIMENSIONLESS,
            "long_name": "0 contact, 1 other fluid, 2 fluid percolating along x",
            "flag_values": np.array(list(PHASE_NAMES), dtype=np.int8),
            "flag_meanings": " ".join(PHASE_NAMES.values())})
        attrs.update({
            f"{name}_lx": spec.lx, f"{name}_ly": spec.ly, f"{name}_gamma": spec.gamma,
            f"{name}_lambda_r": spec.lambda_r, f"{name}_lambda_s": spec.lambda_s,
            f"{name}_area_fraction": res.area_fraction,
            f"{name}_fluid_percolates_x": int(percolates(~mask, 0)),
            f"{name}_fluid_percolates_y": int(percolates(~mask, 1)),
            f"{name}_contact_percolates_x": int(contact_percolates(mask, 0)),
            f"{name}_contact_percolates_y": int(contact_percolates(mask, 1)),
        })
        if job.model != "bearing":  # a rigid cut has no load
            attrs[f"{name}_pressure"] = res.pressure
        log.info("%s: a_c = %.4f, fluid percolates x: %d, y: %d", name, res.area_fraction,
                 attrs[f"{name}_fluid_percolates_x"], attrs[f"{name}_fluid_percolates_y"])
    return xr.Dataset(data, attrs=attrs)
