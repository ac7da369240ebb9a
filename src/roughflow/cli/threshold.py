"""``roughflow threshold``: critical contact area a_c* of a surface, per flow direction."""

from __future__ import annotations

import argparse
import logging
import math

from roughflow.citation import threshold_methods
from roughflow.defaults import (
    A_C_STAR_PAPER,
    AXIS_NAMES,
    CONTACT_METHODS,
    DEFAULT_MODEL,
    MODELS,
    THRESHOLD_CONTACT_TOL,
    THRESHOLD_PRESSURE_RANGE,
    THRESHOLD_STRATEGIES,
    THRESHOLD_TOL,
)

from ._common import (
    PRESSURE_UNIT,
    add_backend,
    add_input,
    add_output,
    add_repulsion,
    adhesion_help,
    axis_arg,
    on_backend,
    refuse_given,
    resolve_adhesion,
    track_given,
    warn_if_nonperiodic_scan,
)

log = logging.getLogger(__name__)


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "threshold",
        help="percolation threshold a_c* of the fluid along x and/or y",
        description=(
            "Critical relative contact area a_c* at which the fluid (non-contact, "
            "4-connected) stops spanning the cell along x or y (open boundaries along the "
            "flow, periodic across; paper Sect. 2.2). Elastic/adhesive: bracket refined with "
            "warm-started contact solves until a_hi - a_lo <= tol; bearing: exact sweep. "
            "Writes a_c_star, a_c_star_corrected, a_lo, a_hi, p_lo, p_hi (pressure in "
            f"{PRESSURE_UNIT}) per axis and the list of contact solves."
        ),
    )
    track_given(p)  # the bearing model refuses the search's options (_search_options)
    p_min, p_max = THRESHOLD_PRESSURE_RANGE
    add_input(p, "surface", kinds="surface", what="surface file", metavar="SURFACE.nc",
              help="surface file written by 'roughflow surface'")
    p.add_argument("--axis", type=axis_arg, default=None, metavar="{x,y,both}",
                   help="flow direction: x, y or both (default both: one shared sequence of "
                   "solves)")
    p.add_argument("--model", choices=MODELS, default=DEFAULT_MODEL,
                   help=f"contact model ({DEFAULT_MODEL})")
    p.add_argument("--tol", type=float, default=THRESHOLD_TOL,
                   help=f"largest allowed a_hi - a_lo ({THRESHOLD_TOL:g})")
    p.add_argument("--method", choices=CONTACT_METHODS, default=None,
                   help="contact solver (default: the contact stage's choice per model)")
    p.add_argument("--strategy", choices=THRESHOLD_STRATEGIES,
                   default=THRESHOLD_STRATEGIES[0],
                   help="predict: aimed refinement (default); bisect: plain bisection")
    p.add_argument("--p-min", type=float, default=None,
                   help=f"lowest allowed pressure in {PRESSURE_UNIT} (default {p_min:g} E* "
                        "gbar, gbar the surface's rms gradient)")
    p.add_argument("--p-max", type=float, default=None,
                   help=f"highest allowed pressure in {PRESSURE_UNIT} (default {p_max:g} E* "
                        "gbar)")
    p.add_argument("--p-guess", type=float, default=None,
                   help="first pressure, in [--p-min, --p-max] (default: the contact law's "
                        f"load for a_c = {A_C_STAR_PAPER}, in E* gbar)")
    p.add_argument("--contact-tol", type=float, default=THRESHOLD_CONTACT_TOL,
                   help="tolerance of each contact solve, gap error / rms height "
                        f"({THRESHOLD_CONTACT_TOL:g})")
    p.add_argument("--surface-energy", type=float, default=None,
                   help=adhesion_help("surface energy gamma_s in E* L"))
    p.add_argument("--adhesion-range", type=float, default=None,
                   help="adhesive model: range rho of the adhesion in L")
    p.add_argument("--allow-unbracketed", action="store_true",
                   help="write NaN (bracketed=0) instead of failing when the pressure range "
                        "does not contain the threshold")
    add_repulsion(p)
    add_backend(p)
    add_output(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> None:
    from roughflow.datasets import threshold_dataset
    from roughflow.io import surface_from_dataset, write_dataset
    from roughflow.search import threshold

    on_backend(args)  # CuPy and a GPU, before any work
    surface = surface_from_dataset(args.data["surface"])
    options = _search_options(args, surface.gbar)
    warn_if_nonperiodic_scan(args.data["surface"], args.surface, "threshold")
    adhesion = resolve_adhesion(args.model, args.surface_energy, args.adhesion_range, surface,
                                flags=("--surface-energy", "--adhesion-range"),
                                source=args.surface, repulsion=args.repulsion)
    res = threshold(surface, args.axis, model=args.model, tol=args.tol, adhesion=adhesion,
                    options=options, backend=args.backend)
    if args.axis is not None:
        res = {args.axis: res}
    for ax, r in res.items():
        log.info("a_c*(%s) = %.4f in [%.4f, %.4f] after %d contact solves", AXIS_NAMES[ax],
                 r.a_c_star, r.a_lo, r.a_hi, r.n_solves)
    ds = threshold_dataset(res, surface, adhesion=adhesion)
    ds.attrs["surface_file"] = str(args.surface)
    methods = threshold_methods(args.model, args.method,
                                None if adhesion is None else adhesion.repulsion)
    write_dataset(ds, args.output, provenance=args.provenance.using(*methods))
    n_solves = max(r.n_solves for r in res.values())
    # the raw value is the cells' count; the corrected one (elastic model) differs by a few
    # hundredths on coarse grids, more than any tolerance here: both are named
    corrected = [f"{AXIS_NAMES[ax]} {r.a_c_star_corrected:.4f}" for ax, r in res.items()
                 if args.model == "elastic" and math.isfinite(r.a_c_star_corrected)]
    print(f"{args.output}: {args.model} a_c* (raw contact area) " + ", ".join(
        f"{AXIS_NAMES[ax]} {r.a_c_star:.4f} in [{r.a_lo:.4f}, {r.a_hi:.4f}]"
        for ax, r in res.items()) + (f" ({n_solves} contact solves)" if n_solves else
                                     " (exact sweep)")
          + (f"; perimeter-corrected {', '.join(corrected)}" if corrected else ""))


#: Options of the contact solves of a search: the bearing model's exact sweep solves none.
_SOLVE_FLAGS = ("--strategy", "--p-min", "--p-max", "--p-guess", "--method", "--contact-tol")


def _search_options(args: argparse.Namespace, gbar: float):
    """The :class:`~roughflow.search.SearchOptions` of the arguments for a surface of rms
    gradient ``gbar`` (the default pressures, in E* gbar, scaled to it: a scan's pressures
    are in E*), after refusing those that the model does not use (they would be ignored)."""
    from roughflow.search import scaled_options

    if args.model == "bearing":
        refuse_given(args, _SOLVE_FLAGS, "to --model bearing: its threshold is an exact sweep "
                     "of the heights, without contact solves")
    # a --p-guess outside [--p-min, --p-max] is refused by SearchOptions (first_pressure)
    return scaled_options(
        gbar, args.model, strategy=args.strategy, pressure_range=(args.p_min, args.p_max),
        first_pressure=args.p_guess, contact_tol=args.contact_tol, method=args.method,
        on_unbracketed="nan" if args.allow_unbracketed else "raise")
