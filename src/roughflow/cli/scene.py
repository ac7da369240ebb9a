"""``roughflow scene``: run one job of the sweep workflow and write its netCDF dataset.

The options mirror the job dataclasses of :mod:`roughflow.scenes.jobs` (``cli_args`` of a
job parses back into the same job; tests/test_scene.py checks the round trip), and their
defaults come from :mod:`roughflow.defaults`.
"""

from __future__ import annotations

import argparse
import logging
import time
from typing import TYPE_CHECKING

from roughflow import defaults
from roughflow.defaults import ADHESION_RANGE_OVER_LAMBDA_S, ADHESION_SURFACE_ENERGY_RATIO
from roughflow.errors import InputError

from ._common import add_output, add_repulsion, add_surface_options, refuse_given, track_given

if TYPE_CHECKING:  # the scenes (numpy, xarray) are imported when the command runs
    from roughflow.scenes import ChannelsJob, LadderJob, ThresholdJob

log = logging.getLogger(__name__)

_SURFACE_FLAGS = ("--gamma", "--hurst", "--l-over-lambda-r", "--eps-f",
                  "--points-per-lambda-s", "--aspect")
#: Options of the adhesive model only (ladder scene).
_ADHESION_FLAGS = ("--surface-energy-ratio", "--range-over-lambda-s", "--tabor", "--repulsion")


def _surface_options(p: argparse.ArgumentParser, flags: tuple[str, ...] = _SURFACE_FLAGS,
                     **overrides) -> None:
    g = p.add_argument_group("surface (unit-area cell; lengths in units of L)")
    add_surface_options(g, flags, **overrides)
    seeds = overrides.get("seeds", [0])
    p.add_argument("--seeds", type=int, nargs="+", default=seeds, metavar="SEED",
                   help=f"surface seeds handled by this job ({' '.join(map(str, seeds))})")
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
                         description="Threshold search (elastic: warm-started contact solves; "
                                     "bearing: one height-ordered pass) to the fluid "
                                     "percolation threshold along x and y, for each seed.")
    _surface_options(t)
    t.add_argument("--model", choices=("elastic", "bearing"), default=defaults.DEFAULT_MODEL,
                   help="contact model (elastic)")
    t.add_argument("--tol", type=float, default=defaults.THRESHOLD_TOL,
                   help="largest a_hi - a_lo of the threshold bracket "
                        f"({defaults.THRESHOLD_TOL:g})")
    t.add_argument("--contact-tol", type=float, default=defaults.THRESHOLD_CONTACT_TOL,
                   help="tolerance of each contact solve, gap error / rms height "
                        f"({defaults.THRESHOLD_CONTACT_TOL:g}; docs/accuracy.md: changes a_c* "
                        "by < 4e-5)")
    t.set_defaults(func=run)

    ld = kinds.add_parser("ladder", help="contact ladder + Reynolds flow + theory",
                          description="Contact at each target area of an increasing ladder "
                                      "(warm-started load search), full Reynolds conductance "
                                      "along x and y where the fluid percolates, Bruggeman and "
                                      "closed forms. The workflow's flow studies pass "
                                      "--l-over-lambda-r (default "
                                      f"{defaults.FLOW_L_OVER_LAMBDA_R:g}, the paper's Fig. 5) "
                                      f"and --a-c-star-alt {defaults.A_C_STAR_ALT:g}; without "
                                      "them a ladder takes the defaults below.")
    track_given(ld)  # adhesion options with another model are refused (_check_ladder)
    _surface_options(ld)
    ld.add_argument("--model", choices=defaults.MODELS, default=defaults.DEFAULT_MODEL,
                    help="contact model (elastic)")
    ld.add_argument("--area-fractions", type=float, nargs="+", required=True, metavar="A",
                    help="target contact areas, increasing, each in (0, 1)")
    ld.add_argument("--area-tol", type=float, default=defaults.LADDER_AREA_TOL,
                    help="largest |a_c - target| of a step (the perimeter-corrected a_c for "
                         f"the elastic model) ({defaults.LADDER_AREA_TOL:g})")
    theory_stars = ", ".join(f"{k} {v:g}" for k, v in defaults.A_C_STAR_THEORY.items())
    ld.add_argument("--a-c-star", type=float, default=None,
                    help=f"a_c* of the theory lines (default per model: {theory_stars})")
    ld.add_argument("--a-c-star-alt", type=float, default=None,
                    help="a second a_c* for the isotropic Bruggeman line (none; the "
                         f"workflow's flow studies pass {defaults.A_C_STAR_ALT:g}, the "
                         "dotted line of Fig. 5a)")
    ld.add_argument("--surface-energy-ratio", type=float, default=ADHESION_SURFACE_ENERGY_RATIO,
                    help="gamma_s / v_ela^full of the adhesive model "
                         f"({ADHESION_SURFACE_ENERGY_RATIO}, the paper's case)")
    rng = ld.add_mutually_exclusive_group()
    rng.add_argument("--range-over-lambda-s", type=float, default=None,
                     help="interaction range rho / lambda_s of the adhesive model (the "
                          "paper's case: "
                          + ", ".join(f"{v} {k}" for k, v in ADHESION_RANGE_OVER_LAMBDA_S.items())
                          + ")")
    rng.add_argument("--tabor", type=float, default=None,
                     help="Tabor parameter instead of the range (sets rho from R_c)")
    add_repulsion(ld)
    ld.set_defaults(func=run)

    ch = defaults.CHANNELS
    c = kinds.add_parser("channels", help="Fig. 1: isotropic 0.5 x 2 cell vs stretched cell",
                         description="Isotropic rectangular cell (lx/ly = 1/gamma) and the "
                                     "gamma-stretched square cell from the same phases, pressed "
                                     "to the target contact area; heights, gap, phase maps.")
    # the two cells' aspects follow from gamma: no --aspect (refused if given)
    _surface_options(c, _SURFACE_FLAGS[:-1], gamma=ch["gamma"], hurst=ch["hurst"],
                     eps_f=ch["eps_f"], l_over_lambda_r=ch["l_over_lambda_r"],
                     seeds=[ch["seed"]], points_per_lambda_s=ch["points_per_lambda_s"])
    c.add_argument("--aspect", type=float, default=None, help=argparse.SUPPRESS)
    c.add_argument("--area-fraction", type=float, default=ch["area_fraction"],
                   help=f"target a_c ({ch['area_fraction']:g})")
    c.add_argument("--model", choices=("elastic", "bearing"), default=ch["model"],
                   help=f"contact model ({ch['model']})")
    c.set_defaults(func=run)


def job_from_args(args: argparse.Namespace) -> ChannelsJob | ThresholdJob | LadderJob:
    """The job dataclass described by the parsed arguments."""
    from roughflow.scenes import ChannelsJob, LadderJob, SurfaceParams, ThresholdJob

    if args.kind == "channels":
        _check_channels(args)
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
    _check_ladder(args)
    adhesion = {} if args.repulsion is None else {"repulsion": args.repulsion}
    return LadderJob(**adhesion, surface=surface, model=args.model, seeds=tuple(args.seeds),
                     area_fractions=tuple(args.area_fractions), a_c_star=args.a_c_star,
                     a_c_star_alt=args.a_c_star_alt, area_tol=args.area_tol, tabor=args.tabor,
                     surface_energy_ratio=args.surface_energy_ratio,
                     range_over_lambda_s=args.range_over_lambda_s)


def _check_channels(args: argparse.Namespace) -> None:
    """Refuse the surface options that the channels job has no field for."""
    if args.aspect is not None:
        raise InputError(f"--aspect {args.aspect:g} does not apply to the channels scene: its "
                         "cells' aspects follow from --gamma (the isotropic cell has lx/ly = "
                         "1/gamma, the stretched one is square)")
    if len(args.seeds) > 1:
        raise InputError(f"the channels scene takes one seed, got --seeds "
                         f"{' '.join(map(str, args.seeds))} (run it once per seed)")


def _check_ladder(args: argparse.Namespace) -> None:
    """Refuse adhesion options with a model that has no adhesion (the workflow's jobs pass
    them for --model adhesive only, LadderJob.cli_args)."""
    if args.model != "adhesive":
        refuse_given(args, _ADHESION_FLAGS, f"to --model {args.model}, only to --model "
                     "adhesive")


def run(args: argparse.Namespace) -> None:
    from dataclasses import replace

    from roughflow.io import write_dataset
    from roughflow.scenes import job_methods
    from roughflow.scenes import run as run_job

    job = job_from_args(args)
    t0 = time.perf_counter()
    log.info("job %s (%s)", job.job_id, job.kind)
    ds = run_job(job, threads=args.threads)
    provenance = replace(args.provenance, threads=args.threads).using(*job_methods(job))
    write_dataset(ds, args.output, provenance=provenance)
    log.info("wrote %s in %.1f s", args.output, time.perf_counter() - t0)
