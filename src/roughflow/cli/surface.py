"""``roughflow surface``: generate a random-phase surface and write it to netCDF."""

from __future__ import annotations

import argparse
import logging
from typing import TYPE_CHECKING

from roughflow.errors import InputError

from ._common import add_output, add_surface_options, dest_of, refuse_given, track_given

if TYPE_CHECKING:  # numpy is imported when the command runs, not for --help
    from roughflow.surface import SurfaceSpec

log = logging.getLogger(__name__)

#: Options of the explicit grid (--lx, --ly: its cell) and of the sweep numbers.
GRID_FLAGS = ("--lx", "--ly")
SWEEP_FLAGS = ("--l-over-lambda-r", "--eps-f", "--points-per-lambda-s", "--aspect")


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "surface",
        help="generate a random-phase rough surface",
        description=(
            "Generate a random-phase rough surface (paper Eq. 1-2) and write heights(x, y) "
            "with every parameter as an attribute. Give either the grid explicitly "
            "(--nx --ny --lambda-r --lambda-s) or the sweep's dimensionless numbers "
            "(--l-over-lambda-r --eps-f --points-per-lambda-s). Lengths are in units of "
            "the cell side L; heights are normalised to the rms gradient."
        ),
    )
    track_given(p)  # each form refuses the other's options (spec_from_args)
    add_surface_options(p, ("--hurst", "--gamma", "--rolloff"))
    p.add_argument("--seed", type=int, default=0, help="random seed of the phases (0)")
    p.add_argument("--rms-slope", type=float, default=1.0, help="rms gradient (1)")
    g = p.add_argument_group("explicit grid (all four needed; lx, ly default to 1)")
    g.add_argument("--nx", type=int, help="grid points along x")
    g.add_argument("--ny", type=int, help="grid points along y")
    g.add_argument("--lx", type=float, default=1.0, help="cell length along x (1)")
    g.add_argument("--ly", type=float, default=1.0, help="cell length along y (1)")
    g.add_argument("--lambda-r", type=float, help="roll-off wavelength")
    g.add_argument("--lambda-s", type=float, help="short-wavelength cutoff")
    s = p.add_argument_group("sweep numbers (used when --nx is not given)")
    add_surface_options(s, SWEEP_FLAGS)
    add_output(p)
    p.set_defaults(func=run)


def spec_from_args(args: argparse.Namespace) -> SurfaceSpec:
    explicit = (args.nx, args.ny, args.lambda_r, args.lambda_s)
    if any(v is not None for v in explicit):
        return _explicit_spec(args)
    refuse_given(args, GRID_FLAGS, "without an explicit grid (--nx --ny --lambda-r "
                 "--lambda-s): the sweep numbers make a unit-area cell, shaped by --aspect")
    from roughflow.surface import SurfaceSpec

    spec = SurfaceSpec.from_sweep(
        gamma=args.gamma, hurst=args.hurst, l_over_lambda_r=args.l_over_lambda_r,
        eps_f=args.eps_f, points_per_lambda_s=args.points_per_lambda_s,
        aspect=args.aspect, seed=args.seed, rolloff=args.rolloff,
    )
    if args.rms_slope != 1.0:
        from dataclasses import replace

        spec = replace(spec, rms_slope=args.rms_slope)
    return spec


def _explicit_spec(args: argparse.Namespace):
    from roughflow.surface import SurfaceSpec

    names = ("--nx", "--ny", "--lambda-r", "--lambda-s")
    missing = [n for n in names if getattr(args, dest_of(n)) is None]
    if missing:
        raise InputError(f"an explicit grid needs {', '.join(missing)} as well")
    refuse_given(args, SWEEP_FLAGS, "to an explicit grid (--nx --ny --lambda-r "
                 "--lambda-s --lx --ly set the cell)")
    return SurfaceSpec(
        nx=args.nx, ny=args.ny, lx=args.lx, ly=args.ly, hurst=args.hurst,
        gamma=args.gamma, lambda_r=args.lambda_r, lambda_s=args.lambda_s,
        seed=args.seed, rms_slope=args.rms_slope, rolloff=args.rolloff,
    )


def run(args: argparse.Namespace) -> None:
    from roughflow.io import surface_to_dataset, write_dataset
    from roughflow.surface import generate

    spec = spec_from_args(args)
    log.info("surface: %d x %d grid, gamma=%g H=%g lambda_r=%g lambda_s=%g seed=%d", spec.nx,
             spec.ny, spec.gamma, spec.hurst, spec.lambda_r, spec.lambda_s, spec.seed)
    surface = generate(spec)
    write_dataset(surface_to_dataset(surface), args.output,
                  provenance=args.provenance.using("surface"))
    print(f"{args.output}: {spec.nx} x {spec.ny} points, {spec.lx:g} x {spec.ly:g} (L), "
          f"H {spec.hurst:g}, gamma {spec.gamma:g}, rms height {surface.heights.std():.4g}, "
          f"rms gradient {spec.rms_slope:g}")
