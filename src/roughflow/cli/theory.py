"""``roughflow theory``: effective-medium and Persson-theory predictions.

Two forms:

* ``roughflow theory RESULT.nc``: a file with a ``gap`` variable (dims ending in x, y;
  any leading dimension is a list of samples, e.g. pressures): isotropic Bruggeman
  (Eq. 5-6), both anisotropic forms (Eq. 7-9) and the closed form (Eq. 16) per sample.
* ``roughflow theory [SURFACE.nc] --pressures ...``: Persson theory a_c(p), mean gap(p)
  and sigma(p) from the spectrum of a surface file (its spec when it has one, else its
  measured spectrum) or, without a file, of the spec given by the sweep options.

A table goes to stdout; ``-o out.nc`` also writes a self-describing dataset.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from roughflow import defaults
from roughflow.defaults import (
    A_C_STAR_PAPER,
    A_C_STAR_THEORY,
    DEFAULT_MODEL,
    MODELS,
    PERSSON_ENERGY_FACTOR,
    PERSSON_PRESSURES,
)
from roughflow.errors import InputError

from ._common import (
    PRESSURE_UNIT,
    add_input,
    add_output,
    add_surface_options,
    refuse_given,
    track_given,
)

if TYPE_CHECKING:  # numpy is imported when a command runs, not for --help
    import numpy as np

DEFAULT_PRESSURES = ",".join(f"{p:g}" for p in PERSSON_PRESSURES)
#: The options of the spec without a file (besides --gamma), and of Persson theory.
SPEC_FLAGS = ("--hurst", "--l-over-lambda-r", "--eps-f", "--points-per-lambda-s", "--aspect",
              "--rolloff")
PERSSON_FLAGS = ("--pressures", "--energy-factor")


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "theory",
        help="Bruggeman, closed-form and Persson-theory conductance predictions",
        description=(
            "With a file holding 'gap' (a contact/flow result): isotropic Bruggeman (Eq. 5-6), "
            "anisotropic Bruggeman in Persson's form (Eq. 7-8) and the corrected form (Eq. 9), "
            "and the closed form (Eq. 16) for every gap field in it. With a surface file, or "
            "without a file (spec from the sweep options): Persson theory a_c(p), mean gap(p) "
            "and sigma(p) = Eq. 16 over --pressures. Units: E* = 1, lengths in L, eta = 1."
        ),
    )
    track_given(p)  # each form refuses the options of the others (_check_form)
    add_input(p, "file", kinds=("gap", "surface"), what="input file", nargs="?", default=None,
              metavar="FILE.nc",
              help="netCDF file with 'gap' (result) or 'heights' (surface); optional")
    p.add_argument("--a-c-star", type=float, default=None,
                   help="percolation threshold a_c* in (0, 1) (default: per --kind, the value "
                        "the flow figures' theory lines use: " + ", ".join(
                            f"{k} {v:g}" for k, v in A_C_STAR_THEORY.items())
                        + f"; the paper's large-system elastic value is {A_C_STAR_PAPER})")
    p.add_argument("--kind", choices=MODELS, default=None,
                   help="closed-form kind of Eq. 16 (default: the file's 'model' attribute "
                        "when it is one of these, else elastic)")
    p.add_argument("--eta", type=float, default=1.0, help="viscosity (1)")
    g = p.add_argument_group("gap files")
    g.add_argument("--gamma", type=float, default=None,
                   help="Peklenik number for the anisotropic forms (default: the file's "
                        "spec_gamma attribute, else 1); also the spec's gamma without a file")
    add_input(g, "--flow", kinds="flow", what="flow file", default=None, metavar="FLOW.nc",
              help="flow file of the same gap (roughflow flow; its contact map must equal "
                   "the gap file's): its sigma_x, sigma_y are added to the table and the "
                   "output for comparison")
    g.add_argument("--peklenik", choices=("height", "conductivity"), default="height",
                   help="use the height Peklenik number (--gamma) or estimate the conductivity "
                        "Peklenik number of each gap field from its autocorrelation (height)")
    s = p.add_argument_group("Persson theory (surface file or spec)")
    s.add_argument("--pressures", default=DEFAULT_PRESSURES,
                   help=f"comma-separated pressures in {PRESSURE_UNIT} ({DEFAULT_PRESSURES})")
    s.add_argument("--energy-factor", type=float, default=None,
                   help="correction factor gamma_P of the elastic energy "
                        f"({PERSSON_ENERGY_FACTOR:g}, docs/theory.md)")
    add_surface_options(s, SPEC_FLAGS)
    add_output(p, required=False, help="also write the results to this netCDF file")
    p.set_defaults(func=run)


def _parse_pressures(text: str) -> np.ndarray:
    import numpy as np

    try:
        values = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise InputError(f"--pressures must be comma-separated numbers, got {text!r}") from None
    if not values:
        raise InputError("--pressures is empty")
    return np.asarray(values)


def run(args: argparse.Namespace) -> None:
    from roughflow.io import surface_from_dataset

    ds = args.data["file"]
    _check_form(args, "spec" if ds is None else "gap" if "gap" in ds else "surface")
    if args.file is None:
        _run_persson(args, _spec_from_args(args), source="spec from options")
        return
    path = Path(args.file)
    if "gap" in ds:
        _run_gap(args, ds)
    else:
        surface = surface_from_dataset(ds)
        src = surface.spec if surface.spec is not None else surface
        _run_persson(args, src, source=f"{path.name} ({'spec' if surface.spec else 'measured'})",
                     surface=surface)


def _check_form(args: argparse.Namespace, form: str) -> None:
    """Refuse the options that the form (a "gap" file, a "surface" file or the "spec" of
    the options) does not use: they would be ignored."""
    if form == "gap":
        refuse_given(args, (*PERSSON_FLAGS, *SPEC_FLAGS), f"to a gap file "
                     f"({args.file}), only to Persson theory (a surface file or none)")
        if args.peklenik == "conductivity":
            refuse_given(args, ("--gamma",), "with --peklenik conductivity (the "
                         "Peklenik number is estimated from each gap field)")
        return
    if args.flow is not None:
        raise InputError("--flow needs a gap file (roughflow contact) to compare with" if
                         form == "spec" else
                         f"--flow compares with a gap file, but {args.file!r} is a surface")
    refuse_given(args, ("--peklenik",), "without a gap file")
    if form == "surface":
        refuse_given(args, ("--gamma", *SPEC_FLAGS), f"to a surface file "
                     f"({args.file}): its own spectrum is used")


def _spec_from_args(args: argparse.Namespace):
    from roughflow.surface import SurfaceSpec

    return SurfaceSpec.from_sweep(
        gamma=defaults.GAMMA if args.gamma is None else args.gamma, hurst=args.hurst,
        l_over_lambda_r=args.l_over_lambda_r, eps_f=args.eps_f,
        points_per_lambda_s=args.points_per_lambda_s, aspect=args.aspect, rolloff=args.rolloff,
    )


def _kind(args: argparse.Namespace, attrs: dict) -> str:
    if args.kind is not None:
        return args.kind
    model = str(attrs.get("model", DEFAULT_MODEL))
    return model if model in MODELS else DEFAULT_MODEL


def _a_c_star(args: argparse.Namespace, kind: str) -> float:
    """--a-c-star, or the theory lines' value for ``kind`` (defaults.A_C_STAR_THEORY)."""
    return A_C_STAR_THEORY[kind] if args.a_c_star is None else args.a_c_star


def _run_persson(args: argparse.Namespace, src, *, source: str, surface=None) -> None:
    """Persson theory of ``src`` (a spec, or a surface's measured spectrum: a non-periodic
    scan's is that of its mirror-tiled cell); the output describes ``surface`` where the
    spectrum came from a file (its spec, or its scan and reference length)."""
    from roughflow.datasets import persson_dataset
    from roughflow.io import write_dataset
    from roughflow.theory import predict_conductance

    pressures = _parse_pressures(args.pressures)
    kind = args.kind or DEFAULT_MODEL
    a_star = _a_c_star(args, kind)
    energy_factor = PERSSON_ENERGY_FACTOR if args.energy_factor is None else args.energy_factor
    pred = predict_conductance(
        src, pressures, a_c_star=a_star, kind=kind, eta=args.eta,
        energy_factor=energy_factor,
    )
    out = sys.stdout
    out.write(f"# Persson theory + Eq. 16 ({kind}, a_c* = {a_star:g}) from {source}\n")
    gamma = getattr(getattr(src, "spec", src), "gamma", 1.0)
    if gamma != 1.0:  # Persson's a_c(p), u(p) and Eq. 16 know no direction
        out.write(f"# sigma is isotropic: the surface's Peklenik number gamma = {gamma:g} "
                  "enters only through its spectrum; sigma_x and sigma_y come from the "
                  "anisotropic Bruggeman forms of a gap file (roughflow theory GAP.nc)\n")
    out.write(f"{'pressure':>12} {'a_c':>10} {'mean_gap':>12} {'sigma':>12}\n")
    for p_, a, u, sg in zip(pred.pressure, pred.area_fraction, pred.mean_gap, pred.sigma,
                             strict=True):
        out.write(f"{p_:12.5g} {a:10.5f} {u:12.5g} {sg:12.5g}\n")
    if args.output is None:
        return
    ds = persson_dataset(pred, src if surface is None else surface, eta=args.eta,
                         energy_factor=energy_factor, description=source)
    write_dataset(ds, args.output, provenance=args.provenance.using("persson", "closed_form"))


def _cell(ds, nx: int, ny: int) -> tuple[float, float]:
    if "lx" in ds.attrs:
        lx = float(ds.attrs["lx"])
    elif "x" in ds.coords and ds.sizes["x"] > 1:
        lx = float(ds["x"][1] - ds["x"][0]) * nx
    else:
        lx = 1.0
    if "ly" in ds.attrs:
        ly = float(ds.attrs["ly"])
    elif "y" in ds.coords and ds.sizes["y"] > 1:
        ly = float(ds["y"][1] - ds["y"][0]) * ny
    else:
        ly = lx * ny / nx
    return lx, ly


def _read_flow(path: str, fl, masks: np.ndarray | None, gap_shape) -> dict[str, list[float]]:
    """sigma_x, sigma_y of a ``roughflow flow`` file (variables or attributes), checked to
    belong to the gap fields: a flow file holds one field, whose contact map must equal the
    gap file's (else the comparison would be with another gap's conductance)."""
    import numpy as np

    n = gap_shape[0]
    contact = np.asarray(fl["contact"].transpose("x", "y").values, dtype=bool)
    if n != 1 or contact.shape != tuple(gap_shape[1:]):
        raise InputError(f"flow file {path!r} holds one {contact.shape} field, the gap file "
                         f"{n} of shape {tuple(gap_shape[1:])}: not the same gap")
    if masks is not None and (differ := int((masks[0] != contact).sum())):
        raise InputError(f"flow file {path!r} belongs to another gap: its contact map differs "
                         f"from the gap file's in {differ} of {contact.size} cells")
    out = {}
    for ax in ("x", "y"):
        name = f"sigma_{ax}"
        if name in fl:
            vals = np.atleast_1d(np.asarray(fl[name].values, dtype=np.float64)).ravel()
        elif name in fl.attrs:
            vals = np.atleast_1d(float(fl.attrs[name]))
        else:
            vals = np.full(n, np.nan)
        if vals.size != n:
            raise InputError(f"{path!r} has {vals.size} values of {name}, the gap file {n}")
        out[f"{name}_reynolds"] = [float(v) for v in vals]
    return out


#: Output columns of a gap file: name -> (units key, long_name).
_GAP_COLUMNS = {
    "area_fraction": ("1", "relative contact area (fraction of sigma = 0 cells)"),
    "mean_gap": ("L", "mean gap over the cell"),
    "sigma_bruggeman": ("sigma", "isotropic Bruggeman conductance, Eq. 5-6"),
    "sigma_nc": ("sigma", "non-contact conductivity, Eq. 13"),
    "peklenik": ("1", "Peklenik number used in Eq. 7-9"),
    "sigma_x_corrected": ("sigma", "anisotropic Bruggeman sigma_x, corrected Eq. 9"),
    "sigma_y_corrected": ("sigma", "anisotropic Bruggeman sigma_y, corrected Eq. 9"),
    "gamma_tilde_corrected": ("1", "gamma sqrt(sigma_y/sigma_x), corrected Eq. 9"),
    "sigma_x_persson": ("sigma", "anisotropic Bruggeman sigma_x, Persson Eq. 7"),
    "sigma_y_persson": ("sigma", "anisotropic Bruggeman sigma_y, Persson Eq. 7"),
    "gamma_tilde_persson": ("1", "gamma sqrt(sigma_y/sigma_x), Persson Eq. 7"),
    "sigma_closed_form": ("sigma", "closed-form conductance, Eq. 16"),
    "residual": ("1", "largest relative residual of the self-consistent equations"),
}


def _columns(t) -> dict[str, float]:
    """One row of the gap table from a :class:`roughflow.theory.GapTheory`."""
    return {
        "area_fraction": t.area_fraction, "mean_gap": t.mean_gap,
        "sigma_bruggeman": t.sigma_isotropic, "sigma_nc": t.sigma_nc, "peklenik": t.peklenik,
        "sigma_x_corrected": t.corrected.sigma_x, "sigma_y_corrected": t.corrected.sigma_y,
        "gamma_tilde_corrected": t.corrected.gamma_tilde,
        "sigma_x_persson": t.persson.sigma_x, "sigma_y_persson": t.persson.sigma_y,
        "gamma_tilde_persson": t.persson.gamma_tilde,
        "sigma_closed_form": t.sigma_closed_form, "residual": t.residual,
    }


def _conductivity_peklenik(args: argparse.Namespace, gap, lx: float, ly: float, mask,
                           index: int | None) -> float:
    """:func:`roughflow.theory.conductivity_peklenik` of one gap field, its refusal naming
    the file and the field (``index`` among several, else None)."""
    from roughflow.theory import conductivity_peklenik

    try:
        return conductivity_peklenik(gap, lx, ly, contact=mask, eta=args.eta)
    except InputError as e:
        which = "'gap'" if index is None else f"'gap' field {index}"
        raise InputError(f"--peklenik conductivity of {args.file} ({which}): {e}") from None


def _run_gap(args: argparse.Namespace, ds) -> None:
    import numpy as np
    import xarray as xr

    from roughflow.datasets.units import DIMENSIONLESS, LENGTH_UNITS, SIGMA_UNITS
    from roughflow.io import write_dataset
    from roughflow.theory import effective_dimension, gap_theory
    from roughflow.units import REFERENCE_ATTRS

    gap = ds["gap"]
    if gap.ndim < 2 or gap.ndim > 3:
        raise InputError(f"'gap' must have 2 or 3 dimensions (…, x, y), got {gap.dims}")
    spatial = ("x", "y") if {"x", "y"} <= set(gap.dims) else gap.dims[-2:]
    lead = [d for d in gap.dims if d not in spatial]
    gap = gap.transpose(*lead, *spatial)
    contact = ds["contact"].transpose(*lead, *spatial) if "contact" in ds else None
    fields = np.asarray(gap.values, dtype=np.float64).reshape(-1, *gap.shape[-2:])
    masks = (None if contact is None
             else np.asarray(contact.values, dtype=bool).reshape(fields.shape))
    nx, ny = fields.shape[1:]
    lx, ly = _cell(ds, nx, ny)
    gamma = args.gamma
    if gamma is None:
        gamma = float(ds.attrs.get("spec_gamma", defaults.GAMMA))
    kind = _kind(args, ds.attrs)
    a_star = _a_c_star(args, kind)
    cols: dict[str, list[float]] = {k: [] for k in _GAP_COLUMNS}
    for i, u in enumerate(fields):
        mask = None if masks is None else masks[i]
        g = (_conductivity_peklenik(args, u, lx, ly, mask, i if len(fields) > 1 else None)
             if args.peklenik == "conductivity" else gamma)
        t = gap_theory(u, a_c_star=a_star, contact=mask, gamma=g, kind=kind, eta=args.eta,
                       noncontact=True)
        for k, v in _columns(t).items():
            cols[k].append(float(v))
    if args.flow and masks is None:
        masks = (fields <= 0)  # a gap file without a contact map: contact = closed cells
    reynolds = (_read_flow(args.flow, args.data["flow"], masks, fields.shape) if args.flow
                else {})
    cols.update(reynolds)
    out = sys.stdout
    out.write(f"# Bruggeman (a_c* = {a_star}, D = {effective_dimension(a_star):.4f}) and "
              f"Eq. 16 ({kind}); Peklenik number of Eq. 7-9: "
              + (f"gamma = {gamma:g}, the surface's (heights)" if args.peklenik == "height"
                 else "each gap field's, from its conductivity's autocorrelation") + "\n")
    heads = ("a_c", "mean_gap", "sigma_iso", "sx_corr", "sy_corr", "sx_pers", "sy_pers",
             "closed_form")
    keys = ("area_fraction", "mean_gap", "sigma_bruggeman", "sigma_x_corrected",
            "sigma_y_corrected", "sigma_x_persson", "sigma_y_persson", "sigma_closed_form")
    if reynolds:
        heads += ("sx_reynolds", "sy_reynolds")
        keys += ("sigma_x_reynolds", "sigma_y_reynolds")
    out.write(" ".join(f"{h:>12}" for h in heads) + "\n")
    for i in range(fields.shape[0]):
        out.write(" ".join(f"{cols[k][i]:12.5g}" for k in keys) + "\n")
    if args.output is None:
        return
    dim = lead[0] if lead else "sample"
    coords = {}
    if lead and dim in ds.coords:
        attrs = {"units": DIMENSIONLESS, "long_name": dim, **dict(ds[dim].attrs)}
        coords[dim] = (dim, ds[dim].values, attrs)
    else:
        coords[dim] = (dim, np.arange(fields.shape[0]),
                       {"units": DIMENSIONLESS, "long_name": "sample"})
    units = {"1": DIMENSIONLESS, "L": LENGTH_UNITS, "sigma": SIGMA_UNITS}
    meta = {k: (units[u], ln) for k, (u, ln) in _GAP_COLUMNS.items()}
    meta["peklenik"] = (DIMENSIONLESS, f"Peklenik number used in Eq. 7-9 ({args.peklenik})")
    meta["sigma_closed_form"] = (SIGMA_UNITS, f"closed-form conductance, Eq. 16 ({kind})")
    for ax in ("x", "y") if reynolds else ():
        meta[f"sigma_{ax}_reynolds"] = (SIGMA_UNITS, f"full Reynolds conductance along {ax} "
                                        f"(from {Path(args.flow).name})")
    res = xr.Dataset(
        {k: (dim, np.asarray(cols[k]), {"units": u_, "long_name": ln})
         for k, (u_, ln) in meta.items()},
        coords=coords,
        attrs={"title": "roughflow theory: Bruggeman and closed-form conductances",
               "a_c_star": a_star, "kind": kind, "eta": args.eta, "lx": lx, "ly": ly,
               "peklenik_source": args.peklenik, "gamma": gamma},
    )
    # what the gap's surface was, and the SI values of the units (a scan's L), so that
    # units.registry(res.attrs) converts this file as it does the gap file
    reference = {attr for attr, _ in REFERENCE_ATTRS.values()}
    res.attrs.update({k: v for k, v in ds.attrs.items()
                      if k in reference or k.startswith(("spec_", "scan_"))})
    methods = ("bruggeman", "closed_form", *(("reynolds",) if reynolds else ()))
    write_dataset(res, args.output, provenance=args.provenance.using(*methods))
