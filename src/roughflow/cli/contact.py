"""``roughflow contact``: solve the contact of a surface file and write the gap field."""

from __future__ import annotations

import argparse
import logging
import time
from typing import TYPE_CHECKING

from roughflow.citation import contact_methods
from roughflow.defaults import (
    CONTACT_METHODS,
    CONTACT_TOL,
    CONTACT_TOL_MAX,
    CONTACT_TOL_MIN,
    DEFAULT_MODEL,
    MODELS,
)
from roughflow.errors import InputError

from ._common import (
    PRESSURE_UNIT,
    add_backend,
    add_input,
    add_output,
    add_repulsion,
    adhesion_help,
    hardness_in_e_star,
    number_or_quantity,
    on_backend,
    pressure_in_e_star,
    refuse_given,
    require_resolved_pressure,
    resolve_adhesion,
    track_given,
    warn_if_nonperiodic_scan,
)

if TYPE_CHECKING:  # xarray is imported when the command runs, not for --help
    import xarray as xr

log = logging.getLogger(__name__)


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "contact",
        help="elastic, adhesive or bearing-area contact of a surface file",
        description=(
            "Press the rigid rough surface of SURFACE.nc (written by 'roughflow surface') onto a "
            "flat elastic half-space (E* = 1, periodic, frictionless) under the mean pressure "
            f"--pressure (in {PRESSURE_UNIT}), or cut it with a flat plane (--model bearing "
            "--area-fraction A). Writes gap(x, y), contact(x, y) and contact_pressure(x, y) "
            "with every scalar of the result and every surface parameter as attributes."
        ),
    )
    track_given(p)  # the bearing model refuses the solver's options (_check_model_options)
    add_input(p, "surface", kinds="surface", what="surface file", metavar="SURFACE.nc",
              help="surface file ('roughflow surface')")
    p.add_argument("--pressure", type=number_or_quantity, default=None,
                   help=f"mean applied pressure (elastic, adhesive) in {PRESSURE_UNIT}, or "
                        "with its unit (400MPa) and --modulus")
    p.add_argument("--modulus", default=None,
                   help="contact modulus E* of the pair (e.g. 200GPa): --pressure may then "
                        "carry its unit, and the output records E* (ref_pressure_Pa) so "
                        "that roughflow.units.registry converts its pressures to Pa")
    p.add_argument("--hardness", type=number_or_quantity, default=None,
                   help=f"elastic model: cap the local pressure at this hardness (elastic-"
                        f"perfectly-plastic; in {PRESSURE_UNIT}, or with its unit, e.g. "
                        "2GPa, and --modulus; by gfmd, or --method cg; not on the GPU); writes "
                        "the plastic mask and "
                        "depth (docs/contact.md, 'Hardness')")
    p.add_argument("--model", choices=MODELS, default=DEFAULT_MODEL,
                   help="elastic (hard wall), adhesive (short-range adhesion) or bearing "
                        "(overlap model, no elasticity) (elastic)")
    p.add_argument("--area-fraction", type=float, default=None,
                   help="target relative contact area of the bearing model, in [0, 1]")
    p.add_argument("--method", choices=CONTACT_METHODS, default=None,
                   help="cg: constrained conjugate gradients (Polonsky-Keer); gfmd: "
                        "mass-weighted GFMD (default: gfmd, the faster one; "
                        "docs/contact.md)")
    p.add_argument("--tol", type=float, default=CONTACT_TOL,
                   help=f"residual: largest gap error in units of the rms height, "
                        f"{CONTACT_TOL_MIN:g} - {CONTACT_TOL_MAX:g} ({CONTACT_TOL:g})")
    p.add_argument("--max-iter", type=int, default=None,
                   help="iteration cap; not converging by then is an error (exit 3)")
    p.add_argument("--surface-energy", type=float, default=None,
                   help=adhesion_help("surface energy gamma_s (units E* L)"))
    p.add_argument("--adhesion-range", "--range", type=float, default=None,
                   dest="adhesion_range",
                   help="adhesive model: range rho of the cosine attraction (units L); "
                        "--adhesion-range as in `threshold`, --range its older name")
    add_repulsion(p)
    add_backend(p)
    add_output(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> None:
    from roughflow.contact import solve
    from roughflow.datasets import contact_dataset
    from roughflow.io import surface_from_dataset, write_dataset

    on_backend(args)  # CuPy and a GPU, before any work
    _check_model_options(args)
    pressure, modulus, hardness = _load(args)
    surface = surface_from_dataset(args.data["surface"])
    if args.model != "bearing":  # the bearing model is local: no edges to join
        warn_if_nonperiodic_scan(args.data["surface"], args.surface, "contact")
        _warn_if_large_strain(args.pressure, pressure, modulus)
    # the elastic solve's floor in Pa (a load that is not positive: the solve's own refusal)
    if args.model == "elastic" and modulus is not None and pressure > 0:
        from roughflow.contact.solve import resolved_load_floor

        require_resolved_pressure("--pressure", pressure * modulus,
                                  resolved_load_floor(surface.gbar, surface.shape) * modulus,
                                  args.modulus, surface.shape, surface.gbar)
    adhesion = resolve_adhesion(args.model, args.surface_energy, args.adhesion_range, surface,
                                flags=("--surface-energy", "--adhesion-range"), source=args.surface,
                                repulsion=args.repulsion)
    t0 = time.perf_counter()
    result = solve(
        surface, pressure, model=args.model, method=args.method,
        area_fraction=args.area_fraction, tol=args.tol, max_iter=args.max_iter,
        adhesion=adhesion, backend=args.backend, hardness=hardness,
    )
    # the bearing model cuts the heights: it has no pressure to report (NaN in the result)
    load = "" if result.model == "bearing" else f"p = {result.pressure:.6g}"
    log.info("%s contact (%s) on %d x %d%s -> a_c = %.5f (%d iterations, residual %.1e, "
             "%.2f s)", result.model, result.method, *surface.shape, load and f": {load}",
             result.area_fraction, result.iterations, result.residual,
             time.perf_counter() - t0)
    methods = contact_methods(result.model, result.method,
                              None if adhesion is None else adhesion.repulsion)
    if hardness is not None:
        methods += ("hardness",)
    ds = contact_dataset(surface, result, adhesion, tol=args.tol)
    if modulus is not None:
        from roughflow.units import REF_PRESSURE, REFERENCE_ATTRS

        ds.attrs[REFERENCE_ATTRS[REF_PRESSURE][0]] = modulus
        load += f" ({result.pressure * modulus:.6g} Pa)"
    plastic = ""
    if hardness is not None:
        cap = f"{hardness:.6g}" + ("" if modulus is None else f" ({hardness * modulus:.6g} Pa)")
        plastic = f", plastic {result.plastic_fraction:.5f} (hardness {cap})"
    write_dataset(ds, args.output, provenance=args.provenance.using(*methods))
    print(f"{args.output}: {result.model} contact{load and f', {load}'}: a_c = "
          f"{result.area_fraction:.5f}{plastic}, mean gap {_gap_text(result.mean_gap, ds)}")


def _gap_text(gap: float, ds: xr.Dataset) -> str:
    """The mean gap (in L) for the summary line, in metres too where the contact file
    records L (``ref_length_m``, as that of an imported scan does)."""
    from roughflow.units import REF_LENGTH, REFERENCE_ATTRS

    length = ds.attrs.get(REFERENCE_ATTRS[REF_LENGTH][0])
    if length is None:
        return f"{gap:.6g} (lengths in L)"
    return f"{gap:.6g} L = {gap * float(length):.6g} m (L = {float(length):.6g} m)"


def _warn_if_large_strain(given: float | str, pressure: float, modulus: float | None) -> None:
    """Warn where --pressure (``given``; ``pressure`` in E*, the ``modulus`` in Pa or None)
    is at or above E* (:func:`roughflow.leak.large_strain`): solved all the same, but
    strains of order one are outside the linear-elastic model."""
    from roughflow.leak import LARGE_STRAIN_WARNING, large_strain

    if not large_strain(pressure):
        return
    shown = given if isinstance(given, str) else f"{given:g}"
    log.warning(LARGE_STRAIN_WARNING, f"--pressure {shown} is",
                f"{pressure:.4g} E*" + ("" if modulus is None
                                        else f" = {pressure * modulus:.4g} Pa"))


def _load(args: argparse.Namespace) -> tuple[float | None, float | None, float | None]:
    """(the load in E*, the modulus in Pa or None, the hardness in E* or None) from
    --pressure, --modulus and --hardness; a load not below the hardness is refused here, in
    the options' words and units."""
    from roughflow.contact import require_below_hardness
    from roughflow.units import parse_quantity

    modulus = (None if args.modulus is None
               else parse_quantity(args.modulus, "pressure", "--modulus"))
    load = pressure_in_e_star(args.pressure, modulus, "--pressure")
    hardness = hardness_in_e_star(args.hardness, modulus)
    if hardness is not None:
        if load is not None:
            require_below_hardness(load, hardness, load_text=f"--pressure {args.pressure}",
                                   hardness_text=f"--hardness {args.hardness}")
    return load, modulus, hardness


def _check_model_options(args: argparse.Namespace) -> None:
    """Refuse options that the chosen model does not use (they would be ignored), and a
    missing load in the command's words (the library's says ``pressure=``)."""
    if args.hardness is not None and args.model != "elastic":
        raise InputError(f"--hardness applies to --model elastic only, not --model "
                         f"{args.model}" + (": it cuts the heights and has no pressure to cap"
                                            if args.model == "bearing" else ""))
    if args.hardness is not None and args.backend != "cpu":
        raise InputError(f"--hardness is solved on the CPU (the GPU path has no pressure "
                         f"cap): leave --backend {args.backend} out")
    if args.model != "bearing":
        if args.pressure is None:
            raise InputError(f"--model {args.model} needs --pressure (the mean pressure in "
                             "E* gbar); --area-fraction is the bearing model's")
        return
    if args.pressure is not None:
        raise InputError("--model bearing takes --area-fraction, not --pressure")
    if args.area_fraction is None:
        raise InputError("--model bearing needs --area-fraction (the contact area it cuts "
                         "the heights at)")
    refuse_given(args, ("--method", "--tol", "--max-iter", "--modulus"), "to --model "
                 "bearing: it has no load and no "
                 "solver (it cuts the heights at the level of --area-fraction)")
