"""``roughflow threshold``: critical contact area a_c* of a surface, per flow direction."""

from __future__ import annotations

import argparse

import numpy as np
import xarray as xr

from roughflow.errors import InputError
from roughflow.io import read_surface, write_dataset

from ._common import add_output, axis_arg

AXIS_NAMES = ("x", "y")


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "threshold",
        help="percolation threshold a_c* of the fluid along x and/or y",
        description=(
            "Critical relative contact area a_c* at which the fluid (non-contact, "
            "4-connected) stops spanning the cell along x or y (open boundaries along the "
            "flow, periodic across; paper Sect. 2.2). Elastic/adhesive: bracket refined with "
            "warm-started contact solves until a_hi - a_lo <= tol; bearing: exact sweep. "
            "Writes a_c_star, a_lo, a_hi, p_lo, p_hi (pressure in E* gbar) and n_solves "
            "per axis."
        ),
    )
    p.add_argument("surface", help="surface netCDF file written by 'roughflow surface'")
    p.add_argument("--axis", type=axis_arg, default=None, metavar="{x,y,both}",
                   help="flow direction: x, y or both (both: one shared sequence of solves)")
    p.add_argument("--model", choices=("elastic", "adhesive", "bearing"), default="elastic",
                   help="contact model (elastic)")
    p.add_argument("--tol", type=float, default=2e-3,
                   help="largest allowed a_hi - a_lo (2e-3)")
    p.add_argument("--method", choices=("cg", "gfmd"), default=None,
                   help="contact solver (default: the contact stage's choice per model)")
    p.add_argument("--strategy", choices=("predict", "bisect"), default="predict",
                   help="predict: aimed refinement (default); bisect: plain bisection")
    p.add_argument("--p-min", type=float, default=1e-4,
                   help="lowest allowed pressure in E* gbar (1e-4)")
    p.add_argument("--p-max", type=float, default=4.0,
                   help="highest allowed pressure in E* gbar (4)")
    p.add_argument("--p-guess", type=float, default=None,
                   help="first pressure (default from a = erf(sqrt(pi) p) at a = 0.415)")
    p.add_argument("--contact-tol", type=float, default=1e-5,
                   help="tolerance of each contact solve, gap error / rms height (1e-5)")
    p.add_argument("--surface-energy", type=float, default=None,
                   help="adhesive model: surface energy gamma_s in E* L")
    p.add_argument("--adhesion-range", type=float, default=None,
                   help="adhesive model: range rho of the adhesion in L")
    p.add_argument("--allow-unbracketed", action="store_true",
                   help="write NaN (bracketed=0) instead of failing when the pressure range "
                        "does not contain the threshold")
    add_output(p)
    p.set_defaults(func=run)


def threshold_dataset(results: dict, surface_path: str, surface) -> xr.Dataset:
    """Dataset with one entry per flow direction (dimension ``direction``)."""
    axes = sorted(results)
    r = [results[a] for a in axes]

    def var(name, values, units, long_name):
        return ("direction", np.asarray(values), {"units": units, "long_name": long_name})

    ds = xr.Dataset(
        {
            "a_c_star": var("a_c_star", [t.a_c_star for t in r], "1",
                            "critical relative contact area (midpoint of a_lo, a_hi)"),
            "a_lo": var("a_lo", [t.a_lo for t in r], "1",
                        "contact area at which the fluid still spans"),
            "a_hi": var("a_hi", [t.a_hi for t in r], "1",
                        "contact area at which the fluid no longer spans"),
            "p_lo": var("p_lo", [t.p_lo for t in r], "E* gbar", "pressure at a_lo"),
            "p_hi": var("p_hi", [t.p_hi for t in r], "E* gbar", "pressure at a_hi"),
            "bracketed": var("bracketed", [int(t.bracketed) for t in r], "1",
                             "1 if the threshold was bracketed within the pressure range"),
        },
        coords={"direction": ("direction", [AXIS_NAMES[a] for a in axes],
                              {"long_name": "flow direction (x = axis 0, y = axis 1)"})},
        attrs={
            "title": "roughflow percolation threshold",
            "model": r[0].model,
            "tol": r[0].tol,
            "n_solves": r[0].n_solves,
            "surface_file": surface_path,
            "lx": surface.lx,
            "ly": surface.ly,
            "messages": " | ".join(t.message for t in r if t.message) or "none",
        },
    )
    if surface.spec is not None:
        ds.attrs.update({f"spec_{k}": v for k, v in surface.spec.as_attrs().items()})
    if r[0].solves:
        s = np.asarray(r[0].solves, dtype=float)
        ds["solve_pressure"] = ("solve", s[:, 0], {"units": "E* gbar",
                                                   "long_name": "pressure of each contact solve"})
        ds["solve_area_fraction"] = ("solve", s[:, 1], {
            "units": "1", "long_name": "contact area of each contact solve"})
        ds["solve_iterations"] = ("solve", s[:, 2].astype(np.int64), {
            "units": "1", "long_name": "solver iterations of each contact solve"})
        ds["solve_residual"] = ("solve", s[:, 3], {
            "units": "1", "long_name": "residual of each contact solve (gap error / rms height)"})
    return ds


def run(args: argparse.Namespace) -> None:
    from roughflow.percolation import threshold

    adhesion = None
    if args.model == "adhesive":
        if args.surface_energy is None or args.adhesion_range is None:
            raise InputError("--model adhesive needs --surface-energy and --adhesion-range")
        from roughflow.contact import Adhesion

        adhesion = Adhesion(surface_energy=args.surface_energy, range=args.adhesion_range)
    elif args.surface_energy is not None or args.adhesion_range is not None:
        raise InputError("--surface-energy/--adhesion-range are only for --model adhesive")
    surface = read_surface(args.surface)
    res = threshold(
        surface, args.axis, model=args.model, tol=args.tol, method=args.method,
        strategy=args.strategy, adhesion=adhesion, p_guess=args.p_guess,
        p_range=(args.p_min, args.p_max), contact_tol=args.contact_tol,
        on_unbracketed="nan" if args.allow_unbracketed else "raise",
    )
    if args.axis is not None:
        res = {args.axis: res}
    write_dataset(threshold_dataset(res, str(args.surface), surface), args.output)
