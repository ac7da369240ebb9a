"""``roughflow scene``: run one job of the sweep workflow and write its netCDF dataset."""

from __future__ import annotations

import argparse
import logging
import time

from roughflow.contact.adhesion import PAPER_RANGE_OVER_LAMBDA_S, PAPER_SURFACE_ENERGY_RATIO
from roughflow.io import write_dataset

from ._common import add_output

log = logging.getLogger(__name__)


def _surface_options(p: argparse.ArgumentParser, *, lists: bool = True) -> None:
    g = p.add_argument_group("surface (unit-area cell; lengths in units of L)")
    g.add_argument("--gamma", type=float, default=1.0,
                   help="Peklenik number; > 1 stretches along x (1)")
    g.add_argument("--hurst", type=float, default=0.8, help="Hurst exponent in (0, 1] (0.8)")
    g.add_argument("--l-over-lambda-r", type=float, default=None,
                   help="L / lambda_r (default: the paper's 4 max(sqrt(gamma), 1/sqrt(gamma)))")
    g.add_argument("--eps-f", type=float, default=1 / 16, help="lambda_s / lambda_r (1/16)")
    g.add_argument("--points-per-lambda-s", type=float, default=8.0,
                   help="grid points per shortest wavelength (8)")
    g.add_argument("--aspect", type=float, default=1.0, help="lx / ly of the cell (1)")
    p.add_argument("--seeds", type=int, nargs="+", default=[0], metavar="SEED",
                   help="surface seeds handled by this job (0)")
    p.add_argument("--threads", type=int, default=None,
                   help="FFT threads (default: env ROUGHFLOW_FFT_THREADS or 1)")
    add_output(p)


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "scene", help="run one sweep job (threshold, ladder or channels) -> netCDF",
        description="Run one job of the sweep workflow and write a self-describing netCDF "
                    "dataset (parameters as coordinates, units on every variable). Progress "
                    "goes to the log (use roughflow -v scene ... 2> job.log).")
    kinds = p.add_subparsers(dest="kind", metavar="KIND", required=True)

    t = kinds.add_parser("threshold", help="percolation thresholds a_c*(x), a_c*(y), no flow",
                         description="Contact bisection (elastic) or height-ordered pass "
                                     "(bearing) to the fluid percolation threshold along x and "
                                     "y, for each seed.")
    _surface_options(t)
    t.add_argument("--model", choices=("elastic", "adhesive", "bearing"), default="elastic",
                   help="contact model (elastic)")
    t.add_argument("--tol", type=float, default=2e-3,
                   help="bisection tolerance on the contact area (0.002)")
    t.add_argument("--contact-tol", type=float, default=1e-4,
                   help="tolerance of each contact solve, gap error / rms height (1e-4; "
                        "docs/accuracy.md: changes a_c* by < 4e-5)")
    t.set_defaults(func=run)

    ld = kinds.add_parser("ladder", help="contact ladder + Reynolds flow + theory",
                          description="Contact along an increasing area ladder (warm-started "
                                      "loads), full Reynolds conductance along x and y where "
                                      "the fluid percolates, Bruggeman and closed forms.")
    _surface_options(ld)
    ld.add_argument("--model", choices=("elastic", "adhesive", "bearing"), default="elastic",
                    help="contact model (elastic)")
    ld.add_argument("--area-fractions", type=float, nargs="+", required=True, metavar="A",
                    help="target contact areas, increasing")
    ld.add_argument("--a-c-star", type=float, default=0.4,
                    help="a_c* of the theory lines (0.4)")
    ld.add_argument("--a-c-star-alt", type=float, default=None,
                    help="a second a_c* for the isotropic Bruggeman line (none)")
    ld.add_argument("--surface-energy-ratio", type=float, default=PAPER_SURFACE_ENERGY_RATIO,
                    help="gamma_s / v_ela^full of the adhesive model "
                         f"({PAPER_SURFACE_ENERGY_RATIO}, the paper's case)")
    rng = ld.add_mutually_exclusive_group()
    rng.add_argument("--range-over-lambda-s", type=float, default=None,
                     help="interaction range rho / lambda_s of the adhesive model "
                          f"({PAPER_RANGE_OVER_LAMBDA_S}, the paper's case)")
    rng.add_argument("--tabor", type=float, default=None,
                     help="Tabor parameter instead of the range (sets rho from R_c)")
    ld.set_defaults(func=run)

    c = kinds.add_parser("channels", help="Fig. 1: isotropic 0.5 x 2 cell vs stretched cell",
                         description="Isotropic rectangular cell (lx/ly = 1/gamma) and the "
                                     "gamma-stretched square cell from the same phases, pressed "
                                     "to the target contact area; heights, gap, phase maps.")
    _surface_options(c)
    c.set_defaults(gamma=4.0, eps_f=0.1, l_over_lambda_r=4.0, seeds=[1])
    c.add_argument("--area-fraction", type=float, default=0.4, help="target a_c (0.4)")
    c.add_argument("--model", choices=("elastic", "bearing"), default="elastic",
                   help="contact model (elastic)")
    c.set_defaults(func=run)


def job_from_args(args: argparse.Namespace):
    """The job dataclass described by the parsed arguments."""
    from roughflow.scenes import ChannelsJob, LadderJob, SurfaceParams, ThresholdJob

    if args.kind == "channels":
        return ChannelsJob(gamma=args.gamma, hurst=args.hurst,
                           l_over_lambda_r=args.l_over_lambda_r, eps_f=args.eps_f,
                           area_fraction=args.area_fraction, model=args.model,
                           seed=args.seeds[0], points_per_lambda_s=args.points_per_lambda_s)
    surface = SurfaceParams(gamma=args.gamma, hurst=args.hurst,
                            l_over_lambda_r=args.l_over_lambda_r, eps_f=args.eps_f,
                            points_per_lambda_s=args.points_per_lambda_s, aspect=args.aspect)
    if args.kind == "threshold":
        return ThresholdJob(surface=surface, model=args.model, seeds=tuple(args.seeds),
                            tol=args.tol, contact_tol=args.contact_tol)
    rho = args.range_over_lambda_s
    if rho is None and args.tabor is None:
        rho = PAPER_RANGE_OVER_LAMBDA_S
    return LadderJob(surface=surface, model=args.model, seeds=tuple(args.seeds),
                     area_fractions=tuple(args.area_fractions), a_c_star=args.a_c_star,
                     a_c_star_alt=args.a_c_star_alt, tabor=args.tabor,
                     surface_energy_ratio=args.surface_energy_ratio, range_over_lambda_s=rho)


def run(args: argparse.Namespace) -> None:
    from roughflow.scenes import run as run_job

    job = job_from_args(args)
    t0 = time.perf_counter()
    log.info("job %s (%s)", job.job_id, job.kind)
    ds = run_job(job, threads=args.threads)
    write_dataset(ds, args.output)
    log.info("wrote %s in %.1f s", args.output, time.perf_counter() - t0)


def build_parser_for_tests() -> argparse.ArgumentParser:
    """The full ``roughflow`` parser (used by tests to round-trip job arguments)."""
    from roughflow.cli import build_parser

    return build_parser()
