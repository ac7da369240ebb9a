"""``roughflow accuracy``: the accuracy budget of a_c* and sigma (docs/accuracy.md).

``resolution`` and ``tol`` append JSON-lines records to their record log under ``--out``
(printed as they come) and, when they complete, write the whole log as a netCDF dataset
beside it; ``report`` turns the datasets into tables, CSV and plots there. The options and
their defaults are :mod:`roughflow.convergence.options`; the work is
:mod:`roughflow.convergence`.
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Callable
from dataclasses import Field, fields
from pathlib import Path

from roughflow.convergence.options import FIT_MIN_PPL, ResolutionOptions, ToleranceOptions
from roughflow.convergence.records import (
    dataset_file,
    report_files,
    resolution_file,
    tolerance_file,
)

from ._common import add_output_folder

OUT = "results/benchmarks"
#: the option classes' fields by name: the defaults of the options
RES, TOL = ({f.name: f for f in fields(c)} for c in (ResolutionOptions, ToleranceOptions))


def _default(of: dict[str, Field], name: str) -> object:
    value = of[name].default
    return list(value) if isinstance(value, tuple) else value


def _shown(value: float | list[float]) -> str:
    return " ".join(f"{v:g}" for v in value) if isinstance(value, list) else f"{value:g}"


def _option(p: argparse.ArgumentParser, flag: str, of: dict[str, Field], text: str, *,
            name: str | None = None, kind: type = float) -> None:
    """``flag`` with the default of the options field ``name`` (default: the flag's)."""
    name = name or flag[2:].replace("-", "_")
    default = _default(of, name)
    nargs = {"nargs": "+"} if isinstance(default, list) else {}
    p.add_argument(flag, dest=name, type=kind, default=default, metavar=name.upper(),
                   help=f"{text} ({_shown(default)})", **nargs)


def _out(p: argparse.ArgumentParser, files: Callable[[argparse.Namespace], list[str]]) -> None:
    add_output_folder(p, "--out", default=OUT, files=files, help="output folder")


def _study_files(log: Path) -> list[str]:
    """The names of a study's record log and of the dataset written from it."""
    return [log.name, dataset_file(log).name]


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "accuracy", help="accuracy budget: error of a_c* and sigma against wall time",
        description="Numerical error of a_c* and sigma against grid resolution, contact "
                    "tolerance and bisection tolerance, with wall times (docs/accuracy.md). "
                    "resolution and tol append JSON-lines records to their record log under "
                    "--out (convergence_*.jsonl, from which a rerun resumes) and, when they "
                    "complete, write the whole log as a netCDF dataset beside it "
                    "(convergence_*.nc); report writes the tables (markdown, CSV) and plots "
                    "from the datasets there.")
    phases = p.add_subparsers(dest="phase", metavar="PHASE", required=True)

    r = phases.add_parser(
        "resolution", help="a_c*, a_c and sigma against grid resolution",
        description="Per seed, one surface generated at the finest resolution and sampled "
                    "down to every coarser one (the same continuum surface): a_c* along x and "
                    "y with the contact-line faces at the threshold, and sigma_x at a_c = "
                    "0.2, 0.35 (or, with --no-sigma, the contact law's fixed loads). Records "
                    "already in the record log are not computed again; a completed run "
                    "writes the log as convergence_resolution[_gGAMMA].nc.")
    _out(r, lambda a: _study_files(resolution_file("", a.gamma)))
    _option(r, "--seeds", RES, "surface seeds", kind=int)
    _option(r, "--ppl", RES, "points per lambda_s (each divides the largest)", kind=int)
    _option(r, "--gamma", RES, "Peklenik number (the file name carries it)")
    r.add_argument("--l-over-lambda-r", type=float, default=None,
                   help="L / lambda_r (default: the paper's)")
    r.add_argument("--sigma", action=argparse.BooleanOptionalAction, default=None,
                   help="sigma at a_c = 0.2, 0.35 (flow solves); default: for gamma 1 only")
    _option(r, "--fixed-targets", RES, "without --sigma: a_c of the contact law's fixed "
                                       "loads (perimeter constant fit)")
    _option(r, "--bisect-tol", RES, "bisection tol (a_hi - a_lo) of the thresholds")
    _option(r, "--threshold-contact-tol", RES, "contact tol inside the threshold searches")
    _option(r, "--contact-tol", RES, "contact tol of the fixed-area and fixed-load solves")
    _option(r, "--area-tol", RES, "how close a_c must come to the sigma targets")
    r.set_defaults(func=run_resolution)

    t = phases.add_parser(
        "tol", help="a_c*, a_c and sigma against contact and bisection tolerances",
        description="At one resolution: a_c, mean gap and sigma against the contact "
                    "tolerance (cold solves at fixed load), a_c* against the contact "
                    "tolerance inside the threshold search and against the bisection "
                    "tolerance. The smallest value of each list is the reference. Records "
                    "already in the record log are not computed again; a completed run "
                    "writes the log as convergence_tol.nc.")
    _out(t, lambda a: _study_files(tolerance_file("")))
    _option(t, "--seeds", TOL, "surface seeds", kind=int)
    _option(t, "--tol-ppl", TOL, "points per lambda_s of the tolerance study", name="ppl",
            kind=int)
    _option(t, "--contact-tols", TOL, "contact tols (the smallest is the reference)")
    _option(t, "--threshold-contact-tols", TOL,
            "contact tols inside the threshold search (the smallest is the reference)")
    _option(t, "--threshold-bisect-tol", TOL,
            "bisection tol of the contact-tol study inside the threshold")
    _option(t, "--bisect-tols", TOL, "bisection tols (the smallest is the reference)")
    _option(t, "--threshold-contact-tol", TOL, "contact tol of the bisection-tol study")
    t.set_defaults(func=run_tol)

    rp = phases.add_parser(
        "report", help="tables, CSV and error-versus-time plots of the records",
        description="convergence.md, .csv and the resolution and tolerance plots from the "
                    "isotropic datasets (when the gamma 1 resolution dataset "
                    "convergence_resolution.nc exists; convergence_tol.nc where it exists), "
                    "and the anisotropic report (convergence_anisotropic.*) from every "
                    "resolution dataset (convergence_resolution*.nc) with face counts.")
    _out(rp, lambda a: report_files())
    rp.add_argument("--fit-min-ppl", type=int, default=FIT_MIN_PPL,
                    help="smallest resolution used to fit the perimeter constant "
                         f"({FIT_MIN_PPL})")
    rp.set_defaults(func=run_report)


def _print(rec: dict) -> None:
    print(json.dumps(rec), flush=True)


def resolution_options(args: argparse.Namespace) -> ResolutionOptions:
    """The resolution study's options from the command line (checked: InputError)."""
    return ResolutionOptions(
        seeds=args.seeds, ppl=args.ppl, gamma=args.gamma, l_over_lambda_r=args.l_over_lambda_r,
        sigma=args.sigma, fixed_targets=args.fixed_targets, bisect_tol=args.bisect_tol,
        threshold_contact_tol=args.threshold_contact_tol, contact_tol=args.contact_tol,
        area_tol=args.area_tol)


def tolerance_options(args: argparse.Namespace) -> ToleranceOptions:
    """The tolerance study's options from the command line (checked: InputError)."""
    return ToleranceOptions(
        seeds=args.seeds, ppl=args.ppl, contact_tols=args.contact_tols,
        threshold_contact_tols=args.threshold_contact_tols,
        threshold_bisect_tol=args.threshold_bisect_tol, bisect_tols=args.bisect_tols,
        threshold_contact_tol=args.threshold_contact_tol)


def run_resolution(args: argparse.Namespace) -> None:
    opts = resolution_options(args)  # checked before the solvers are even imported
    from roughflow.convergence.measure import measure_resolution

    measure_resolution(args.out, opts, on_record=_print, provenance=args.provenance)


def run_tol(args: argparse.Namespace) -> None:
    opts = tolerance_options(args)
    from roughflow.convergence.measure import measure_tolerances

    measure_tolerances(args.out, opts, on_record=_print, provenance=args.provenance)


def run_report(args: argparse.Namespace) -> None:
    from roughflow.convergence.report import write_reports

    for written in write_reports(args.out, fit_min_ppl=args.fit_min_ppl):
        print(written.markdown)
