"""``roughflow flow``: Reynolds flow through the gap of a contact file."""

from __future__ import annotations

import argparse
import logging
import math
from typing import TYPE_CHECKING

from roughflow.defaults import (
    AXIS_NAMES,
    FLOW_METHOD,
    FLOW_METHODS,
    FLOW_SIGMA_RTOL,
    FLOW_SIGMA_TOL,
    FLOW_TOL,
)

from ._common import add_input, add_output, axis_arg, warn_if_nonperiodic_scan

if TYPE_CHECKING:  # numpy is imported when the command runs, not for --help
    import numpy as np

log = logging.getLogger(__name__)


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "flow",
        help="Reynolds flow through a contact gap: conductances sigma_x, sigma_y",
        description=(
            "Read gap(x, y) and the cell lengths lx, ly (attributes) from a file written by "
            "`roughflow contact`, solve div(u^3/(12 eta) grad p) = 0 with a unit pressure "
            "drop between reservoirs at the two ends of each requested axis (periodic "
            "across it), and write sigma_x / sigma_y (scalar variables and attributes), "
            "the pressure and the flux fields. sigma = 0 when the gap does not percolate. "
            "sigma is in L^3/eta; for a contact of an imported scan (which records its L in "
            "metres) --viscosity 1mPa.s also gives it in m^3/(Pa s)."
        ),
    )
    add_input(p, "input", kinds="contact", what="contact file", metavar="CONTACT.nc",
              help="contact file with a gap(x, y) variable (roughflow contact)")
    p.add_argument("--axis", type=axis_arg, default=None, metavar="{x,y,both}",
                   help="flow direction(s): x, y or both (both)")
    p.add_argument("--eta", type=float, default=None,
                   help="viscosity eta as a bare number (1): sigma is in L^3 / eta")
    p.add_argument("--viscosity", default=None,
                   help="instead of --eta: the fluid's viscosity with its unit (e.g. 1mPa.s), "
                        "for a contact file that records its length L in metres (a scan from "
                        "roughflow import): the output records it (ref_viscosity_Pa_s, "
                        "eta = 1 in its units) so that roughflow.units.registry converts "
                        "sigma to m^3/(Pa s), and the summary prints sigma in m^3/(Pa s)")
    p.add_argument("--tol", type=float, default=FLOW_TOL,
                   help=f"relative residual of the linear solve ({FLOW_TOL:g})")
    p.add_argument("--sigma-tol", type=float, default=None, metavar="RTOL",
                   help="also stop an iterative solve once sigma is proven accurate to this "
                        f"relative error (at most {FLOW_SIGMA_RTOL:g}), whatever its residual: "
                        "fewer iterations, a less converged pressure field (off; the sweeps "
                        f"use {FLOW_SIGMA_TOL:g})")
    p.add_argument("--method", choices=FLOW_METHODS, default=FLOW_METHOD,
                   help="linear solver: auto (direct for small systems and thin flowing "
                        "clusters, else rs; an AMG result whose fluxes do not balance "
                        "is solved again directly), rs (Ruge-Stueben AMG + CG), sa (smoothed "
                        "aggregation + CG), direct (LDL^T), cg")
    add_output(p, "--plot", dest="plot", required=False, suffixes=(".png", ".pdf", ".svg"),
               metavar="FILE.png",
               help="also draw the flux magnitude over the contact map (one panel per axis)")
    add_output(p)
    p.set_defaults(func=run)


def _read_gap(ds):
    """gap, contact mask and cell lengths of a contact dataset (kind checked on reading)."""
    from roughflow.errors import require_positive

    lx, ly = require_positive("lx", ds.attrs["lx"]), require_positive("ly", ds.attrs["ly"])
    import numpy as np

    gap = ds["gap"].values.astype(np.float64)
    contact = ds["contact"].values.astype(bool) if "contact" in ds else gap <= 0
    open_contact = contact & (gap > 0)
    if open_contact.any():
        # a contact cell is closed (roughflow's own files give it gap 0; `roughflow theory`
        # closes it too): a user's file with a gap there solved it open, while the output's
        # contact map drew it closed
        log.warning("%d cells marked as contact have a gap > 0 (up to %.3g): closed, as "
                    "contact", int(open_contact.sum()), float(gap[open_contact].max()))
        gap = np.where(contact, 0.0, gap)
    return gap, contact, lx, ly


def run(args: argparse.Namespace) -> None:
    from roughflow.datasets import flow_dataset
    from roughflow.flow import check_sigma_tol, solve
    from roughflow.io import dataset_writer, figure_writer, write_together
    from roughflow.provenance import PROVENANCE_ATTRS

    sigma_tol = check_sigma_tol(args.sigma_tol)
    ds_in = args.data["input"]
    eta, viscosity = _viscosity(args, ds_in)
    gap, contact, lx, ly = _read_gap(ds_in)
    warn_if_nonperiodic_scan(ds_in, args.input, "flow")
    axes = (0, 1) if args.axis is None else (args.axis,)
    results = {}
    for ax in axes:
        results[ax] = solve(gap, ax, lx=lx, ly=ly, eta=eta, tol=args.tol,
                            method=args.method, sigma_tol=sigma_tol)
        r = results[ax]
        log.info("sigma_%s = %.6e (%s, %d iterations, residual %.1e, sigma's error at most "
                 "%.1e)", AXIS_NAMES[ax], r.sigma, r.method, r.iterations, r.residual,
                 r.sigma_error)
    out = flow_dataset(results, contact, lx=lx, ly=ly, eta=eta, tol=args.tol,
                       sigma_tol=sigma_tol)
    out.attrs["source"] = str(args.input)
    from roughflow.units import REF_VISCOSITY, REFERENCE_ATTRS

    # the SI values of the reference units hold for this file's lengths too (a scan's L):
    # kept under their own names, so that units.registry(ds.attrs) converts the flow file
    reference = {attr for attr, _ in REFERENCE_ATTRS.values()}
    for k, v in ds_in.attrs.items():
        # the contact's provenance continues in this file's history and references
        if k in reference:
            out.attrs[k] = v
        elif k not in ("title", "lx", "ly", *PROVENANCE_ATTRS):
            out.attrs[f"contact_{k}"] = v
    if viscosity is not None:  # the unit of this file's eta (= 1) and sigma
        out.attrs[REFERENCE_ATTRS[REF_VISCOSITY][0]] = viscosity
    writers = [dataset_writer(out, args.output, provenance=args.provenance.using("reynolds"))]
    if args.plot:
        writers.append(figure_writer(_plot(results, contact), args.plot, dpi=120))
    write_together(writers)  # the flow file and its plot appear together or not at all
    print(f"{args.output}: " + ", ".join(f"sigma_{AXIS_NAMES[ax]} = {r.sigma:.6e}"
                                         for ax, r in results.items())
          + f" (L^3 / eta, eta = {eta:g})" + ("" if viscosity is None else _in_si(out, results)))


def _viscosity(args: argparse.Namespace, ds) -> tuple[float, float | None]:
    """(eta of the solve, --viscosity in Pa s or None), after refusing --viscosity with
    --eta, or for a contact file without a physical length (ref_length_m): its sigma, in
    L^3/eta, has no SI value there."""
    from roughflow.errors import InputError

    if args.viscosity is None:
        return (1.0 if args.eta is None else args.eta), None
    if args.eta is not None:
        raise InputError(f"--eta {args.eta:g} and --viscosity {args.viscosity!r}: give one "
                         "(--viscosity sets eta = 1 in its units)")
    from roughflow.units import REF_LENGTH, REFERENCE_ATTRS, parse_quantity

    viscosity = parse_quantity(args.viscosity, "viscosity", "--viscosity")
    key = REFERENCE_ATTRS[REF_LENGTH][0]
    try:
        length = float(ds.attrs.get(key, float("nan")))
    except (TypeError, ValueError):
        length = float("nan")
    if not (math.isfinite(length) and length > 0):
        raise InputError(
            f"--viscosity {args.viscosity!r}: {args.input} records no length in metres "
            f"({key}: a contact of a scan from `roughflow import`), so its sigma in L^3/eta "
            "has no value in m^3/(Pa s) (a modulus, ref_pressure_Pa, does not fix L); give "
            "--eta, in the units of your viscosity, instead")
    return 1.0, viscosity


def _in_si(out, results: dict) -> str:
    """The summary's sigmas in m^3/(Pa s), converted as roughflow.units.registry converts
    the flow file's (its ref_length_m and ref_viscosity_Pa_s)."""
    from roughflow.datasets.units import CONDUCTANCE_SI, SIGMA_UNITS
    from roughflow.units import REF_LENGTH, REF_VISCOSITY, registry

    ureg = registry(out.attrs)
    scales = (f"L = {ureg.Quantity(1, REF_LENGTH).to('m').magnitude:.4g} m, eta = "
              f"{ureg.Quantity(1, REF_VISCOSITY).to('Pa*s').magnitude:.4g} Pa s")
    return f"; in SI ({scales}): " + ", ".join(
        f"sigma_{AXIS_NAMES[ax]} = "
        f"{ureg.Quantity(r.sigma, SIGMA_UNITS).to(CONDUCTANCE_SI).magnitude:.6e}"
        for ax, r in results.items()) + " m^3/(Pa s)"


def _plot(results: dict, contact: np.ndarray):
    # a Figure without pyplot: no backend is selected or switched (savefig renders with Agg)
    from matplotlib.figure import Figure

    from roughflow.figures.flux import plot_flux

    fig = Figure(figsize=(5 * len(results), 4.6))
    axes = fig.subplots(1, len(results), squeeze=False)
    for ax, r in zip(axes[0], results.values(), strict=True):
        plot_flux(r, contact, ax=ax)
    fig.tight_layout()
    return fig
