"""``roughflow contact``: solve the contact of a surface file and write the gap field."""

from __future__ import annotations

import argparse

import numpy as np
import xarray as xr

from roughflow.contact import DEFAULT_TOL, METHODS, MODELS, Adhesion, ContactResult, solve
from roughflow.contact.adhesion import (
    PAPER_RANGE_OVER_LAMBDA_S,
    PAPER_SURFACE_ENERGY_RATIO,
    adhesion_for,
    adhesion_summary,
)
from roughflow.errors import InputError
from roughflow.io import LENGTH_UNITS, grid_coords, read_surface, write_dataset
from roughflow.surface import Surface

from ._common import add_output

PRESSURE_UNITS = "E* gbar (contact modulus times rms gradient; dimensionless)"


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "contact",
        help="elastic, adhesive or bearing-area contact of a surface file",
        description=(
            "Press the rigid rough surface of SURFACE.nc (written by 'roughflow surface') onto a "
            "flat elastic half-space (E* = 1, periodic, frictionless) under the mean pressure "
            "--pressure (units E* gbar), or cut it with a flat plane (--model bearing "
            "--area-fraction A). Writes gap(x, y), contact(x, y) and contact_pressure(x, y) "
            "with every scalar of the result and every surface parameter as attributes."
        ),
    )
    p.add_argument("surface", metavar="SURFACE.nc", help="surface file ('roughflow surface')")
    p.add_argument("--pressure", type=float, default=None,
                   help="mean applied pressure in units of E* gbar (elastic, adhesive)")
    p.add_argument("--model", choices=MODELS, default="elastic",
                   help="elastic (hard wall), adhesive (short-range adhesion) or bearing "
                        "(overlap model, no elasticity) (elastic)")
    p.add_argument("--area-fraction", type=float, default=None,
                   help="target relative contact area of the bearing model, in [0, 1]")
    p.add_argument("--method", choices=METHODS, default=None,
                   help="cg: constrained conjugate gradients (Polonsky-Keer); gfmd: "
                        "mass-weighted GFMD with FIRE (default: gfmd, the faster one; "
                        "docs/contact.md)")
    p.add_argument("--tol", type=float, default=DEFAULT_TOL,
                   help=f"residual: largest gap error in units of the rms height ({DEFAULT_TOL:g})")
    p.add_argument("--max-iter", type=int, default=None,
                   help="iteration cap; not converging by then is an error (exit 3)")
    p.add_argument("--surface-energy", type=float, default=None,
                   help="adhesive model: surface energy gamma_s (units E* L); without "
                        "--surface-energy and --range: the paper's adhesive case, gamma_s = "
                        f"{PAPER_SURFACE_ENERGY_RATIO} v_ela^full and rho = "
                        f"{PAPER_RANGE_OVER_LAMBDA_S} lambda_s (needs a surface file written "
                        "by roughflow surface, which records lambda_s)")
    p.add_argument("--range", type=float, default=None, dest="adhesion_range",
                   help="adhesive model: range rho of the cosine attraction (units L)")
    add_output(p)
    p.set_defaults(func=run)


def _adhesion(args: argparse.Namespace, surface) -> Adhesion | None:
    given = (args.surface_energy, args.adhesion_range)
    if args.model != "adhesive":
        if any(v is not None for v in given):
            raise InputError("--surface-energy and --range are only for --model adhesive")
        return None
    if all(v is None for v in given):
        if surface.spec is None:
            raise InputError(f"{args.surface} records no lambda_s (not written by roughflow "
                             "surface): give --surface-energy and --range")
        return adhesion_for(surface.heights, surface.lx, surface.ly,
                            gamma_over_v_full=PAPER_SURFACE_ENERGY_RATIO,
                            range=PAPER_RANGE_OVER_LAMBDA_S * surface.spec.lambda_s)
    if any(v is None for v in given):
        raise InputError("--model adhesive needs both --surface-energy and --range "
                         "(or neither, for the paper's adhesive case)")
    return Adhesion(surface_energy=args.surface_energy, range=args.adhesion_range)


def result_to_dataset(surface: Surface, result: ContactResult,
                      adhesion: Adhesion | None = None) -> xr.Dataset:
    """Dataset with gap, contact mask and contact pressure on x, y; scalars as attributes."""
    nx, ny = surface.shape
    ds = xr.Dataset(
        {
            "gap": (("x", "y"), result.gap,
                    {"units": LENGTH_UNITS, "long_name": "interfacial gap u_g >= 0"}),
            "contact": (("x", "y"), result.contact.astype(np.int8),
                        {"units": "1", "long_name": "contact mask (1 = in contact)"}),
            "contact_pressure": (("x", "y"), result.contact_pressure,
                                 {"units": PRESSURE_UNITS,
                                  "long_name": "local contact pressure (negative = tension)"}),
            "heights": (("x", "y"), surface.heights,
                        {"units": LENGTH_UNITS, "long_name": "height of the rigid rough surface"}),
        },
        coords=grid_coords(nx, ny, surface.lx, surface.ly),
        attrs={"title": "roughflow contact", "lx": surface.lx, "ly": surface.ly,
               "e_star": 1.0, **result.scalars()},
    )
    if surface.spec is not None:
        ds.attrs.update({f"spec_{k}": v for k, v in surface.spec.as_attrs().items()})
    if adhesion is not None:
        ds.attrs["surface_energy"] = adhesion.surface_energy
        ds.attrs["adhesion_range"] = adhesion.range
        summary = adhesion_summary(surface.heights, surface.lx, surface.ly, adhesion)
        ds.attrs.update({f"adhesion_{k}": v for k, v in summary.items()})
    return ds


def run(args: argparse.Namespace) -> None:
    if args.model == "bearing" and args.pressure is not None:
        raise InputError("--model bearing takes --area-fraction, not --pressure")
    surface = read_surface(args.surface)
    adhesion = _adhesion(args, surface)
    result = solve(
        surface, args.pressure, model=args.model, method=args.method,
        area_fraction=args.area_fraction, tol=args.tol, max_iter=args.max_iter,
        adhesion=adhesion,
    )
    write_dataset(result_to_dataset(surface, result, adhesion), args.output)
