"""Channels scene (paper Fig. 1): an isotropic 0.5 x 2 cell and its stretched square version.

Both cells have unit area and the same grid; with the same seed the gamma-stretched
square surface is exactly the isotropic rectangular one with x scaled by sqrt(gamma) and
y by 1/sqrt(gamma) (identical q_P on identical index grids), up to the rms-gradient
normalisation. Each is pressed to the target contact area (elastic: pressure bisection on
the area; bearing: direct) and classified into contact, fluid percolating along x (the
cells of spanning clusters) and other fluid.
"""

from __future__ import annotations

import logging

import numpy as np
import xarray as xr

from roughflow.io import LENGTH_UNITS
from roughflow.surface import Surface, generate

from .jobs import ChannelsJob

log = logging.getLogger(__name__)

CLASSES = {0: "contact", 1: "percolating fluid (along x)", 2: "non-percolating fluid"}


def contact_at_area(surface: Surface, target: float, model: str, *, tol: float = 2e-3,
                    max_solves: int = 30, threads: int | None = None):
    """Contact result whose area fraction is within ``tol`` of ``target``.

    Bearing: exact. Elastic: secant/bisection on log(pressure) with warm starts.
    """
    from roughflow import contact

    if model == "bearing":
        return contact.solve(surface, model="bearing", area_fraction=target)
    kw = {} if threads is None else {"threads": threads}
    lo, hi = None, None  # (log p, area) brackets
    lp = np.log(max(target, 1e-3) / 1.77)
    best, prev = None, None
    for n in range(max_solves):
        res = contact.solve(surface, float(np.exp(lp)), model=model, init=prev, **kw)
        prev = res
        a = res.area_fraction
        log.info("contact solve %d: p = %.5g -> a_c = %.4f (%d iterations)", n + 1,
                 res.pressure, a, res.iterations)
        if best is None or abs(a - target) < abs(best.area_fraction - target):
            best = res
        if abs(a - target) <= tol:
            break
        if a < target:
            lo = (lp, a)
        else:
            hi = (lp, a)
        if lo is not None and hi is not None:
            w = (target - lo[1]) / (hi[1] - lo[1])
            lp = lo[0] + min(max(w, 0.1), 0.9) * (hi[0] - lo[0])
        else:
            lp += 0.5 if a < target else -0.5
    return best


def classify(contact_mask: np.ndarray) -> np.ndarray:
    """0 contact, 1 fluid percolating along x, 2 other fluid."""
    from roughflow.percolation import spanning_cells

    open_mask = ~contact_mask
    span = np.asarray(spanning_cells(open_mask, 0), dtype=bool)
    out = np.full(contact_mask.shape, 2, dtype=np.int8)
    out[contact_mask] = 0
    out[span] = 1
    return out


def run_channels(job: ChannelsJob, *, threads: int | None = None) -> xr.Dataset:
    """Heights, gap and phase maps of both cells at the target contact area."""
    from roughflow.percolation import contact_percolates, percolates

    data, attrs = {}, {"title": "roughflow channels scene (paper Fig. 1)", "scene": "channels",
                       "gamma": job.gamma, "target_area_fraction": job.area_fraction,
                       "model": job.model, "seed": job.seed}
    for name, params in zip(("iso", "aniso"), job.surfaces(), strict=True):
        spec = params.spec(job.seed)
        surface = generate(spec)
        log.info("%s: %d x %d grid, %g x %g cell, gamma=%g", name, spec.nx, spec.ny,
                 spec.lx, spec.ly, spec.gamma)
        res = contact_at_area(surface, job.area_fraction, job.model, threads=threads)
        mask = np.asarray(res.contact, dtype=bool)
        phase = classify(mask)
        dims = (f"ix_{name}", f"iy_{name}")
        data[f"heights_{name}"] = (dims, surface.heights, {
            "units": LENGTH_UNITS, "long_name": f"height of the {name} surface"})
        data[f"gap_{name}"] = (dims, res.gap, {"units": LENGTH_UNITS,
                                              "long_name": f"gap of the {name} contact"})
        data[f"phase_{name}"] = (dims, phase, {
            "units": "1", "long_name": "0 contact, 1 fluid percolating along x, 2 other fluid",
            "flag_values": np.array(list(CLASSES), dtype=np.int8),
            "flag_meanings": "contact percolating_fluid non_percolating_fluid"})
        attrs.update({
            f"{name}_lx": spec.lx, f"{name}_ly": spec.ly, f"{name}_gamma": spec.gamma,
            f"{name}_lambda_r": spec.lambda_r, f"{name}_lambda_s": spec.lambda_s,
            f"{name}_area_fraction": res.area_fraction, f"{name}_pressure": res.pressure,
            f"{name}_fluid_percolates_x": int(percolates(~mask, 0)),
            f"{name}_fluid_percolates_y": int(percolates(~mask, 1)),
            f"{name}_contact_percolates_x": int(contact_percolates(mask, 0)),
            f"{name}_contact_percolates_y": int(contact_percolates(mask, 1)),
        })
        log.info("%s: a_c = %.4f, fluid percolates x: %d, y: %d", name, res.area_fraction,
                 attrs[f"{name}_fluid_percolates_x"], attrs[f"{name}_fluid_percolates_y"])
    return xr.Dataset(data, attrs=attrs)
