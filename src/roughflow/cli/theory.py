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
import math
import sys
from pathlib import Path

import numpy as np
import xarray as xr

from roughflow.errors import InputError
from roughflow.io import surface_from_dataset, write_dataset
from roughflow.surface import ROLLOFF_FORMS, SurfaceSpec
from roughflow.theory import (
    DEFAULT_ENERGY_FACTOR,
    KINDS,
    bruggeman,
    bruggeman_anisotropic,
    closed_form,
    conductivity_peklenik,
    local_conductivity,
    noncontact_decomposition,
    predict_conductance,
)

SIGMA_UNITS = "L^3/eta (gap^3/(12 eta); L = cell side)"
DEFAULT_PRESSURES = "0.002,0.005,0.01,0.02,0.05,0.1,0.15,0.2,0.25"


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
    p.add_argument("file", nargs="?", default=None,
                   help="netCDF file with 'gap' (result) or 'heights' (surface); optional")
    p.add_argument("--a-c-star", type=float, default=0.415,
                   help="percolation threshold a_c* in (0, 1) (0.415, the paper's elastic value)")
    p.add_argument("--kind", choices=KINDS, default=None,
                   help="closed-form kind of Eq. 16 (default: the file's 'model' attribute "
                        "when it is one of these, else elastic)")
    p.add_argument("--eta", type=float, default=1.0, help="viscosity (1)")
    g = p.add_argument_group("gap files")
    g.add_argument("--gamma", type=float, default=None,
                   help="Peklenik number for the anisotropic forms (default: the file's "
                        "spec_gamma attribute, else 1); also the spec's gamma without a file")
    g.add_argument("--flow", default=None, metavar="FLOW.nc",
                   help="flow file of the same gap (roughflow flow): its sigma_x, sigma_y are "
                        "added to the table and the output for comparison")
    g.add_argument("--peklenik", choices=("height", "conductivity"), default="height",
                   help="use the height Peklenik number (--gamma) or estimate the conductivity "
                        "Peklenik number of each gap field from its autocorrelation (height)")
    s = p.add_argument_group("Persson theory (surface file or spec)")
    s.add_argument("--pressures", default=DEFAULT_PRESSURES,
                   help=f"comma-separated pressures in E* gbar ({DEFAULT_PRESSURES})")
    s.add_argument("--energy-factor", type=float, default=DEFAULT_ENERGY_FACTOR,
                   help=f"correction factor of the elastic energy ({DEFAULT_ENERGY_FACTOR})")
    s.add_argument("--hurst", type=float, default=0.8, help="Hurst exponent (0.8)")
    s.add_argument("--l-over-lambda-r", type=float, default=None,
                   help="L / lambda_r (default 4 max(sqrt(gamma), 1/sqrt(gamma)))")
    s.add_argument("--eps-f", type=float, default=1 / 16, help="lambda_s / lambda_r (1/16)")
    s.add_argument("--points-per-lambda-s", type=float, default=8.0,
                   help="grid points per shortest wavelength (8)")
    s.add_argument("--aspect", type=float, default=1.0, help="lx / ly of the cell (1)")
    s.add_argument("--rolloff", choices=ROLLOFF_FORMS, default="smooth",
                   help="roll-off form of the spectrum (smooth)")
    p.add_argument("-o", "--output", default=None, metavar="FILE.nc",
                   help="also write the results to this netCDF file")
    p.set_defaults(func=run)


def _parse_pressures(text: str) -> np.ndarray:
    try:
        values = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise InputError(f"--pressures must be comma-separated numbers, got {text!r}") from None
    if not values:
        raise InputError("--pressures is empty")
    return np.asarray(values)


def run(args: argparse.Namespace) -> None:
    if args.file is None:
        _run_persson(args, _spec_from_args(args), source="spec from options")
        return
    path = Path(args.file)
    if not path.exists():
        raise InputError(f"file {str(path)!r} does not exist")
    with xr.open_dataset(path) as ds:
        ds = ds.load()
    if "gap" in ds:
        _run_gap(args, ds)
    elif "heights" in ds:
        surface = surface_from_dataset(ds)
        src = surface.spec if surface.spec is not None else surface
        _run_persson(args, src, source=f"{path.name} ({'spec' if surface.spec else 'measured'})")
    else:
        raise InputError(f"{str(path)!r} has neither 'gap' nor 'heights'")


def _spec_from_args(args: argparse.Namespace) -> SurfaceSpec:
    return SurfaceSpec.from_sweep(
        gamma=1.0 if args.gamma is None else args.gamma, hurst=args.hurst,
        l_over_lambda_r=args.l_over_lambda_r, eps_f=args.eps_f,
        points_per_lambda_s=args.points_per_lambda_s, aspect=args.aspect, rolloff=args.rolloff,
    )


def _kind(args: argparse.Namespace, attrs: dict) -> str:
    if args.kind is not None:
        return args.kind
    model = str(attrs.get("model", "elastic"))
    return model if model in KINDS else "elastic"


def _run_persson(args: argparse.Namespace, src, *, source: str) -> None:
    pressures = _parse_pressures(args.pressures)
    kind = args.kind or "elastic"
    pred = predict_conductance(
        src, pressures, a_c_star=args.a_c_star, kind=kind, eta=args.eta,
        energy_factor=args.energy_factor,
    )
    out = sys.stdout
    out.write(f"# Persson theory + Eq. 16 ({kind}, a_c* = {args.a_c_star}) from {source}\n")
    out.write(f"{'pressure':>12} {'a_c':>10} {'mean_gap':>12} {'sigma':>12}\n")
    for p_, a, u, sg in zip(pred.pressure, pred.area_fraction, pred.mean_gap, pred.sigma,
                             strict=True):
        out.write(f"{p_:12.5g} {a:10.5f} {u:12.5g} {sg:12.5g}\n")
    if args.output is None:
        return
    p_attrs = {"units": "E* gbar", "long_name": "applied mean pressure"}
    ds = xr.Dataset(
        {
            "area_fraction": ("pressure", pred.area_fraction, {
                "units": "1",
                "long_name": "Persson relative contact area erf(sqrt(2) p/(E* gbar))"}),
            "mean_gap": ("pressure", pred.mean_gap, {
                "units": "L", "long_name": "Persson mean gap (Yang & Persson 2008)"}),
            "sigma": ("pressure", pred.sigma, {
                "units": SIGMA_UNITS, "long_name": f"closed-form conductance, Eq. 16 ({kind})"}),
        },
        coords={"pressure": ("pressure", pred.pressure, p_attrs)},
        attrs={
            "title": "roughflow theory: Persson prediction", "source": source, "kind": kind,
            "a_c_star": args.a_c_star, "eta": args.eta, "energy_factor": args.energy_factor,
        },
    )
    _add_spec_attrs(ds, src)
    write_dataset(ds, args.output)


def _add_spec_attrs(ds: xr.Dataset, src) -> None:
    spec = src if isinstance(src, SurfaceSpec) else getattr(src, "spec", None)
    if spec is not None:
        ds.attrs.update({f"spec_{k}": v for k, v in spec.as_attrs().items()})


def _cell(ds: xr.Dataset, nx: int, ny: int) -> tuple[float, float]:
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


def _read_flow(path: str, n: int) -> dict[str, list[float]]:
    """sigma_x, sigma_y of a ``roughflow flow`` file (variables or attributes)."""
    if not Path(path).exists():
        raise InputError(f"flow file {path!r} does not exist")
    with xr.open_dataset(path) as fl:
        fl = fl.load()
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


def _run_gap(args: argparse.Namespace, ds: xr.Dataset) -> None:
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
        gamma = float(ds.attrs.get("spec_gamma", 1.0))
    kind = _kind(args, ds.attrs)
    a_star = args.a_c_star
    cols: dict[str, list[float]] = {k: [] for k in (
        "area_fraction", "mean_gap", "sigma_bruggeman", "sigma_nc", "peklenik",
        "sigma_x_corrected", "sigma_y_corrected", "gamma_tilde_corrected",
        "sigma_x_persson", "sigma_y_persson", "gamma_tilde_persson", "sigma_closed_form",
        "residual")}
    for i, u in enumerate(fields):
        mask = None if masks is None else masks[i]
        sig = local_conductivity(u, args.eta, contact=mask)
        iso = bruggeman(sig, a_c_star=a_star)
        ac = iso.a_c
        g = (conductivity_peklenik(u, lx, ly, contact=mask, eta=args.eta)
             if args.peklenik == "conductivity" else gamma)
        cor = bruggeman_anisotropic(sig, a_c_star=a_star, gamma=g, form="corrected")
        per = bruggeman_anisotropic(sig, a_c_star=a_star, gamma=g, form="persson")
        nc = (noncontact_decomposition(sig, a_c_star=a_star).sigma_nc
              if 0 < (sig > 0).mean() and ac <= a_star else math.nan)
        ubar = float(u.mean())
        for k, v in (
            ("area_fraction", ac), ("mean_gap", ubar), ("sigma_bruggeman", iso.sigma),
            ("sigma_nc", nc), ("peklenik", g),
            ("sigma_x_corrected", cor.sigma_x), ("sigma_y_corrected", cor.sigma_y),
            ("gamma_tilde_corrected", cor.gamma_tilde),
            ("sigma_x_persson", per.sigma_x), ("sigma_y_persson", per.sigma_y),
            ("gamma_tilde_persson", per.gamma_tilde),
            ("sigma_closed_form", closed_form(ubar, ac, a_c_star=a_star, kind=kind, eta=args.eta)),
            ("residual", max(iso.residual, cor.residual, per.residual)),
        ):
            cols[k].append(float(v))
    reynolds = _read_flow(args.flow, fields.shape[0]) if args.flow else {}
    cols.update(reynolds)
    out = sys.stdout
    out.write(f"# Bruggeman (a_c* = {a_star}, D = {1 / (1 - a_star):.4f}) and Eq. 16 ({kind}); "
              f"Peklenik: {args.peklenik}\n")
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
        attrs = {"units": "1", "long_name": dim, **dict(ds[dim].attrs)}
        coords[dim] = (dim, ds[dim].values, attrs)
    else:
        coords[dim] = (dim, np.arange(fields.shape[0]), {"units": "1", "long_name": "sample"})
    meta = {
        "area_fraction": ("1", "relative contact area (fraction of sigma = 0 cells)"),
        "mean_gap": ("L", "mean gap over the cell"),
        "sigma_bruggeman": (SIGMA_UNITS, "isotropic Bruggeman conductance, Eq. 5-6"),
        "sigma_nc": (SIGMA_UNITS, "non-contact conductivity, Eq. 15"),
        "peklenik": ("1", f"Peklenik number used in Eq. 7-9 ({args.peklenik})"),
        "sigma_x_corrected": (SIGMA_UNITS, "anisotropic Bruggeman sigma_x, corrected Eq. 9"),
        "sigma_y_corrected": (SIGMA_UNITS, "anisotropic Bruggeman sigma_y, corrected Eq. 9"),
        "gamma_tilde_corrected": ("1", "gamma sqrt(sigma_y/sigma_x), corrected Eq. 9"),
        "sigma_x_persson": (SIGMA_UNITS, "anisotropic Bruggeman sigma_x, Persson Eq. 7"),
        "sigma_y_persson": (SIGMA_UNITS, "anisotropic Bruggeman sigma_y, Persson Eq. 7"),
        "gamma_tilde_persson": ("1", "gamma sqrt(sigma_y/sigma_x), Persson Eq. 7"),
        "sigma_closed_form": (SIGMA_UNITS, f"closed-form conductance, Eq. 16 ({kind})"),
        "residual": ("1", "largest relative residual of the self-consistent equations"),
    }
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
    res.attrs.update({k: v for k, v in ds.attrs.items() if k.startswith("spec_")})
    write_dataset(res, args.output)
