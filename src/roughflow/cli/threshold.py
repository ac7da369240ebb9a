"""``roughflow threshold``: critical contact area a_c* of a surface, per flow direction."""

from __future__ import annotations

import argparse
import logging
import math
from itertools import pairwise

from roughflow.citation import threshold_methods
from roughflow.defaults import (
    A_C_STAR_PAPER,
    AXIS_NAMES,
    BOUNDARY,
    BOUNDARY_METHODS,
    CONTACT_METHODS,
    DEFAULT_MODEL,
    MODELS,
    THRESHOLD_CONTACT_TOL,
    THRESHOLD_PRESSURE_RANGE,
    THRESHOLD_STRATEGIES,
    THRESHOLD_TOL,
)
from roughflow.errors import InputError

from ._common import (
    PRESSURE_UNIT,
    add_backend,
    add_input,
    add_output,
    add_repulsion,
    adhesion_help,
    axis_arg,
    dest_of,
    given,
    hardness_in_e_star,
    number_or_quantity,
    on_backend,
    pressure_in_e_star,
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
            f"{PRESSURE_UNIT}) per axis and the list of contact solves; with --modulus also "
            "E* in Pa (ref_pressure_Pa: roughflow.units.registry converts p_lo, p_hi to Pa), "
            "and the pressure options take units (50MPa)."
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
    p.add_argument("--p-min", type=number_or_quantity, default=None,
                   help=f"lowest allowed pressure in {PRESSURE_UNIT}, or with its unit (50MPa) "
                        f"and --modulus (default {p_min:g} E* gbar, gbar the surface's rms "
                        "gradient)")
    p.add_argument("--p-max", type=number_or_quantity, default=None,
                   help=f"highest allowed pressure in {PRESSURE_UNIT}, or with its unit and "
                        f"--modulus (default {p_max:g} E* gbar)")
    p.add_argument("--p-guess", type=number_or_quantity, default=None,
                   help="first pressure, in [--p-min, --p-max], in E* or with its unit and "
                        f"--modulus (default: the contact law's load for a_c = "
                        f"{A_C_STAR_PAPER}, in E* gbar)")
    p.add_argument("--modulus", default=None,
                   help="contact modulus E* of the pair (e.g. 200GPa): the output records "
                        "it (ref_pressure_Pa) so that roughflow.units.registry converts "
                        "p_lo, p_hi to Pa, the summary prints them in Pa, and --p-min, "
                        "--p-max, --p-guess, --hardness are then given with their unit")
    p.add_argument("--hardness", type=number_or_quantity, default=None,
                   help=f"elastic model: cap the local contact pressure of every solve at "
                        f"this hardness (elastic-perfectly-plastic, not on the GPU; in "
                        f"{PRESSURE_UNIT}, or with its unit, e.g. 2GPa, and --modulus): the "
                        "threshold of the capped contact; the pressure range ends below it "
                        "(docs/contact.md, 'Hardness')")
    p.add_argument("--boundary", choices=BOUNDARY_METHODS, default="periodic",
                   help="non-periodic treatment of a scan (docs/measured.md, 'Non-periodic "
                        "scans'). periodic (default): the cell as it is (a non-periodic scan "
                        "draws a warning); window, mirror, pad: as `roughflow leak` (whose "
                        f"default for a scan is {BOUNDARY}), the threshold of the analysed "
                        "window by leak's sealing search (roughflow.leak.sealing_search: "
                        "elastic model, default pressure range), p_lo, p_hi nominal "
                        "pressures on the window; they take none of --model adhesive/bearing, "
                        "--strategy, --method, --p-min, --p-max, --p-guess, --backend cupy")
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
    from roughflow.leak import LARGE_STRAIN_WARNING, large_strain
    from roughflow.search import threshold

    on_backend(args)  # CuPy and a GPU, before any work
    surface = surface_from_dataset(args.data["surface"])
    modulus = _modulus(args)
    hardness = _hardness(args, modulus)
    options = _search_options(args, surface.gbar, modulus, hardness)
    adhesion = resolve_adhesion(args.model, args.surface_energy, args.adhesion_range, surface,
                                flags=("--surface-energy", "--adhesion-range"),
                                source=args.surface, repulsion=args.repulsion)
    if args.boundary == "periodic":
        if "boundary" not in given(args):  # given: the user chose the periodic cell
            warn_if_nonperiodic_scan(args.data["surface"], args.surface, "threshold",
                                     treat="--boundary")
        res = threshold(surface, args.axis, model=args.model, tol=args.tol, adhesion=adhesion,
                        options=options, backend=args.backend)
        if args.axis is not None:
            res = {args.axis: res}
    else:
        res = _window_thresholds(args, surface, hardness)
    for ax, r in res.items():
        log.info("a_c*(%s) = %.4f in [%.4f, %.4f] after %d contact solves", AXIS_NAMES[ax],
                 r.a_c_star, r.a_lo, r.a_hi, r.n_solves)
        if large_strain(r.p_hi):  # as roughflow leak flags a sealing pressure (NaN: bearing)
            log.warning(LARGE_STRAIN_WARNING, f"p_hi along {AXIS_NAMES[ax]}",
                        f"{r.p_hi:.4g} E*" + ("" if modulus is None
                                               else f" = {r.p_hi * modulus:.4g} Pa"))
    ds = threshold_dataset(res, surface, adhesion=adhesion)
    ds.attrs["surface_file"] = str(args.surface)
    ds.attrs["boundary"] = args.boundary
    in_pa = ""
    if modulus is not None:
        from roughflow.datasets.units import PRESSURE_UNITS
        from roughflow.units import REF_PRESSURE, REFERENCE_ATTRS, registry

        ds.attrs[REFERENCE_ATTRS[REF_PRESSURE][0]] = modulus
        if hardness is not None:  # as roughflow leak records it
            ds.attrs["hardness_Pa"] = hardness * modulus
        ureg = registry(ds.attrs)  # what a reader of the file gets: p_lo, p_hi in Pa
        in_pa = "; p_lo, p_hi in Pa: " + ", ".join(
            f"{AXIS_NAMES[ax]} [" + ", ".join(
                f"{ureg.Quantity(p, PRESSURE_UNITS).to('Pa').magnitude:.4g}"
                for p in (r.p_lo, r.p_hi)) + "]" for ax, r in res.items())
    methods = threshold_methods(args.model, args.method if hardness is None else "cg",
                                None if adhesion is None else adhesion.repulsion)
    if hardness is not None:
        methods += ("hardness",)
    write_dataset(ds, args.output, provenance=args.provenance.using(*methods))
    n_solves = max(r.n_solves for r in res.values())
    # the raw value is the cells' count; the corrected one (elastic model) differs by a few
    # hundredths on coarse grids, more than any tolerance here: both are named
    corrected = [f"{AXIS_NAMES[ax]} {r.a_c_star_corrected:.4f}" for ax, r in res.items()
                 if args.model == "elastic" and math.isfinite(r.a_c_star_corrected)]
    window = "" if args.boundary == "periodic" else f", boundary {args.boundary}"
    if hardness is not None:
        window += f", hardness {hardness:.6g}" + (
            "" if modulus is None else f" ({hardness * modulus:.6g} Pa)")
    print(f"{args.output}: {args.model} a_c* (raw contact area{window}) " + ", ".join(
        f"{AXIS_NAMES[ax]} {r.a_c_star:.4f} in [{r.a_lo:.4f}, {r.a_hi:.4f}]"
        for ax, r in res.items()) + (f" ({n_solves} contact solves)" if n_solves else
                                     " (exact sweep)")
          + (f"; perimeter-corrected {', '.join(corrected)}" if corrected else "") + in_pa)


#: Options of the contact solves of a search: the bearing model's exact sweep solves none.
_SOLVE_FLAGS = ("--strategy", "--p-min", "--p-max", "--p-guess", "--method", "--contact-tol",
                "--modulus")
#: Options that leak's sealing search (--boundary window, mirror, pad) does not take.
_SEALING_FIXED = ("--strategy", "--p-min", "--p-max", "--p-guess", "--method")


def _check_order(args: argparse.Namespace, pressures: dict[str, float | None]) -> None:
    """InputError naming the given values where --p-min, --p-guess, --p-max (in E*) are not
    positive and finite or are out of order (SearchOptions would name them in E*, not as
    given)."""
    order = [f for f in ("--p-min", "--p-guess", "--p-max") if pressures[f] is not None]
    for flag in order:
        if not (math.isfinite(pressures[flag]) and pressures[flag] > 0):
            raise InputError(f"{flag} {getattr(args, dest_of(flag))} is not a positive, "
                             "finite pressure")
    for lo, hi in pairwise(order):
        equal_refused = (lo, hi) == ("--p-min", "--p-max")  # the guess may be an end
        if pressures[lo] > pressures[hi] or equal_refused and pressures[lo] == pressures[hi]:
            raise InputError(f"{lo} {getattr(args, dest_of(lo))} is not below {hi} "
                             f"{getattr(args, dest_of(hi))}")


def _modulus(args: argparse.Namespace) -> float | None:
    """--modulus in Pa (None where not given)."""
    from roughflow.units import parse_quantity

    return None if args.modulus is None else parse_quantity(args.modulus, "pressure",
                                                            "--modulus")


def _hardness(args: argparse.Namespace, modulus: float | None) -> float | None:
    """--hardness in E* (None where not given), refused with --model bearing or adhesive or
    on the GPU (a --p-min, --p-max, --p-guess not below it: :func:`_search_options`)."""
    if args.hardness is None:
        return None
    if args.model != "elastic":
        raise InputError(f"--hardness {args.hardness} applies to --model elastic only, not "
                         f"--model {args.model}" + (
                             ": it cuts the heights and has no pressure to cap"
                             if args.model == "bearing" else ""))
    if args.backend != "cpu":
        raise InputError(f"--hardness {args.hardness} is solved on the CPU (the GPU path has "
                         f"no pressure cap): leave --backend {args.backend} out")
    return hardness_in_e_star(args.hardness, modulus)


def _window_thresholds(args: argparse.Namespace, surface, hardness: float | None) -> dict:
    """The thresholds of the window of ``surface`` analysed by ``--boundary`` (window,
    mirror, pad): :func:`roughflow.leak.sealing_search` on :func:`roughflow.boundary.embed`,
    as ``roughflow leak`` finds its sealing pressures (nominal pressures in E*; capped at
    ``hardness``, E*, where given). An axis that the default range does not bracket is an
    error unless --allow-unbracketed."""
    from roughflow.boundary import embed
    from roughflow.leak import sealing_search
    from roughflow.search import ThresholdNotBracketed

    res = sealing_search(embed(surface, args.boundary), gbar=surface.gbar, tol=args.tol,
                         contact_tol=args.contact_tol, hardness=hardness)
    if args.axis is not None:
        res = {args.axis: res[args.axis]}
    missed = [r.message for r in res.values() if not r.bracketed]
    if missed and not args.allow_unbracketed:
        raise ThresholdNotBracketed(" | ".join(missed) + " (--allow-unbracketed writes NaN)")
    return res


def _search_options(args: argparse.Namespace, gbar: float, modulus: float | None = None,
                    hardness: float | None = None):
    """The :class:`~roughflow.search.SearchOptions` of the arguments for a surface of rms
    gradient ``gbar`` (the default pressures, in E* gbar, scaled to it: a scan's pressures
    are in E*; given ones in E*, or in Pa with ``modulus``; ``hardness`` in E*), after
    refusing those that the model or the boundary does not use (they would be ignored)."""
    from roughflow.search import scaled_options

    if args.model == "bearing":
        refuse_given(args, _SOLVE_FLAGS, "to --model bearing: its threshold is an exact sweep "
                     "of the heights, without contact solves")
    pressures = {flag: pressure_in_e_star(getattr(args, dest_of(flag)), modulus, flag)
                 for flag in ("--p-min", "--p-max", "--p-guess")}
    if args.boundary != "periodic":
        why = (f"to --boundary {args.boundary}: it runs the sealing search of `roughflow "
               "leak` (elastic model, its default pressure range and solver)")
        if args.model != "elastic":
            raise InputError(f"--model {args.model} does not apply {why}")
        if args.backend != "cpu":
            raise InputError(f"--backend {args.backend} does not apply {why}")
        refuse_given(args, _SEALING_FIXED, why)
        return None
    _check_order(args, pressures)
    if hardness is not None:  # refused in the options' words, not SearchOptions' (E*)
        from roughflow.contact import require_below_hardness

        for flag, value in pressures.items():
            if value is not None:
                require_below_hardness(value, hardness,
                                       load_text=f"{flag} {getattr(args, dest_of(flag))}",
                                       hardness_text=f"--hardness {args.hardness}")
    # a --p-guess outside the default range is refused by SearchOptions (first_pressure)
    return scaled_options(
        gbar, args.model, strategy=args.strategy,
        pressure_range=(pressures["--p-min"], pressures["--p-max"]),
        first_pressure=pressures["--p-guess"], contact_tol=args.contact_tol,
        method=args.method, on_unbracketed="nan" if args.allow_unbracketed else "raise",
        hardness=hardness)
