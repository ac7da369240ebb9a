"""``roughflow leak``: will this seal leak, and how much? (physical units)"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

from roughflow.defaults import (
    BOUNDARY,
    BOUNDARY_METHODS,
    CONTACT_TOL,
    LEAK_MIN_CONTACT_CELLS,
    SEALING_AREA_NOTE,
    THRESHOLD_CONTACT_TOL,
    THRESHOLD_TOL,
)
from roughflow.errors import InputError

from ._common import (
    add_input,
    add_output,
    hardness_in_e_star,
    number_or_quantity,
    require_resolved_pressure,
)

if TYPE_CHECKING:  # numpy and xarray are imported when the command runs, not for --help
    import numpy as np
    import xarray as xr


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "leak",
        help="leak rate and sealing pressure of a surface in physical units",
        description=(
            "Press the rough surface of SURFACE.nc (from `roughflow import`, or a generated "
            "one with --length-scale) onto a flat elastic counterface of contact modulus "
            "--modulus at each nominal pressure of --pressures; print and write the relative "
            "contact area, whether the fluid percolates along x and y, the conductances "
            "sigma_x, sigma_y and the leak rates Q = sigma l dp / w for a seal of width w "
            "(--seal-width, along the flow) and length l (--seal-length, across it) under the "
            "fluid pressure drop dp (--fluid-pressure) with viscosity --viscosity, and the "
            "sealing pressure along each axis (where the fluid stops percolating). "
            "Quantities take units: 200GPa, 1mPa.s, 2mm; --pressures LO:HI:N gives N "
            "logarithmically spaced values. The fluid pressure is taken small against the "
            "contact pressure (it does not push the surfaces apart)."
        ),
    )
    add_input(p, "surface", kinds="surface", what="surface file", metavar="SURFACE.nc",
              help="surface file (roughflow import)")
    p.add_argument("--modulus", required=True, help="contact modulus E*, e.g. 200GPa")
    p.add_argument("--pressures", required=True, metavar="LO:HI:N",
                   help="nominal contact pressures: LO:HI:N (log-spaced) or A,B,C")
    p.add_argument("--fluid-pressure", required=True, help="pressure drop across the seal")
    p.add_argument("--viscosity", required=True, help="fluid viscosity, e.g. 1mPa.s")
    p.add_argument("--seal-width", required=True, help="seal width w along the flow, e.g. 2mm")
    p.add_argument("--seal-length", required=True,
                   help="seal length l across the flow (e.g. the circumference), e.g. 60mm")
    p.add_argument("--length-scale", default=None,
                   help="physical size of the cell side L, for a surface file without one "
                        "(a generated surface)")
    p.add_argument("--boundary", choices=BOUNDARY_METHODS, default=None,
                   help=f"non-periodic treatment (default: {BOUNDARY} for a scan, periodic "
                        "for a periodic surface; docs/measured.md)")
    p.add_argument("--name", default=None, help="label of the surface (default: file stem)")
    p.add_argument("--contact-tol", type=float, default=CONTACT_TOL,
                   help=f"residual of the contact solves of the pressure curve, gap error "
                        f"/ rms height ({CONTACT_TOL:g}); the sealing search solves to "
                        f"{THRESHOLD_CONTACT_TOL:g}, as `threshold` does (docs/measured.md)")
    p.add_argument("--threshold-tol", type=float, default=THRESHOLD_TOL,
                   help=f"width of the sealing bracket in contact area ({THRESHOLD_TOL:g})")
    p.add_argument("--rate-unit", default=None, metavar="UNIT",
                   help="unit of the table's leak rates Q_x, Q_y: a volume per time such as "
                        "mm^3/s, mL/min, uL/h or L/min (default: the output file's m^3/s; the "
                        "file keeps m^3/s whatever this says)")
    p.add_argument("--hardness", type=number_or_quantity, default=None,
                   help="hardness of the softer face, with its unit (e.g. 2GPa): the contact "
                        "pressures of the rows and of the sealing search are capped there "
                        "(elastic-perfectly-plastic; docs/contact.md, "
                        "'Hardness')")
    p.add_argument("--no-sealing", action="store_true",
                   help="skip the sealing-pressure search (often most of the run time); the "
                        "sealing variables of the output are then NaN")
    p.add_argument("--threads", type=int, default=None,
                   help="FFT threads (default: env ROUGHFLOW_FFT_THREADS or 1)")
    add_output(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> None:
    from roughflow.citation import LEAK_METHODS
    from roughflow.contact import require_below_hardness
    from roughflow.datasets import leak_dataset
    from roughflow.io import surface_from_dataset, write_dataset
    from roughflow.leak import check_pressures, check_seal, leak_curve, lowest_resolved_pressure
    from roughflow.units import Scales, parse_quantity, parse_range, parse_rate_unit

    # every quantity is checked before any solve (the surface file was read and checked by
    # the shared input layer)
    modulus = parse_quantity(args.modulus, "pressure", "--modulus")
    pressures = parse_range(args.pressures, "pressure", "--pressures")
    fluid = parse_quantity(args.fluid_pressure, "pressure", "--fluid-pressure")
    eta = parse_quantity(args.viscosity, "viscosity", "--viscosity")
    width = parse_quantity(args.seal_width, "length", "--seal-width")
    length = parse_quantity(args.seal_length, "length", "--seal-length")
    if args.rate_unit is not None:  # format_table converts; checked here, before any solve
        parse_rate_unit(args.rate_unit, "--rate-unit")
    if not isinstance(args.hardness, str | None):  # leak's pressures all carry units
        raise InputError(f"--hardness {args.hardness:g} needs its unit, e.g. 2GPa")
    hardness = hardness_in_e_star(args.hardness, modulus)
    if hardness is not None:
        require_below_hardness(pressures.max(), hardness * modulus,
                               load_text=f"--pressures reach {pressures.max():.4g} Pa, which",
                               hardness_text=f"--hardness {args.hardness}")
    given = (None if args.length_scale is None
             else parse_quantity(args.length_scale, "length", "--length-scale"))
    surface = surface_from_dataset(args.data["surface"])
    if surface.scan is not None and given is not None:
        raise InputError(f"{args.surface} already records its length scale "
                         f"({surface.scan.length_scale:g} m): drop --length-scale")
    if surface.scan is None and given is None:
        raise InputError(f"{args.surface} records no physical length (not from roughflow "
                         "import): give --length-scale, the physical cell side L")
    scales = Scales(length=surface.scan.length_scale if given is None else given,
                    modulus=modulus, viscosity=eta)
    check_seal(surface, scales, fluid_pressure=fluid, seal_width=width, seal_length=length)
    p = check_pressures(scales.pressure_from_si(pressures))
    require_resolved_pressure("--pressures", pressures[0],
                              lowest_resolved_pressure(surface, args.boundary) * modulus,
                              args.modulus, surface.shape, surface.gbar)
    curve = leak_curve(surface, p, boundary=args.boundary, contact_tol=args.contact_tol,
                       threshold_tol=args.threshold_tol, sealing=not args.no_sealing,
                       threads=args.threads, hardness=hardness, modulus=modulus)
    name = args.name or Path(args.surface).stem
    ds = leak_dataset(curve, surface, scales=scales, fluid_pressure=fluid, seal_width=width,
                      seal_length=length, name=name)
    ds.attrs["surface_file"] = str(args.surface)
    write_dataset(ds, args.output,
                  provenance=args.provenance.using(
                      *LEAK_METHODS, *(("cg", "hardness") if hardness is not None else ())))
    print(format_table(ds, rate_unit=args.rate_unit))


#: The note under the table for its rows marked "*".
EMPTY_WINDOW_NOTE = (
    "* the analysed window holds no contact cell: all of the contact lies outside it (in "
    "the border that --boundary window drops), so a_c = 0 and the gap and leak rate of the "
    "row are those of a window held open from outside, not a property of the seal; start "
    "--pressures higher, or use --boundary mirror (the whole scan analysed)")

#: The note under the table for its rows marked "~" (a template: the window's cells along
#: x and y, ``nx`` and ``ny``).
FEW_CELLS_NOTE = (
    f"~ the analysed window holds contact on fewer than {LEAK_MIN_CONTACT_CELLS} of its "
    "{nx} x {ny} cells (a_c times its cells): no contact spot spans more than a few grid "
    "cells, so a_c (over-counted by about 10 % of itself or more) and the gap and leak rate "
    "those spots hold open are under-resolved; start --pressures higher, or check the row "
    "on the scan interpolated to a finer grid")

#: The note under the table for its rows marked "!" (a template: the fluid pressure and the
#: rows' pressures, in Pa).
FLUID_LIFT_NOTE = (
    "! the fluid pressure {fluid} Pa is at or above the contact pressure of these rows "
    "({rows} Pa): on the high-pressure side of the seal it would push the faces apart, and "
    "the model, which leaves the fluid's load on the faces out, does not hold there")

#: The note under the table for its rows marked "^" (a template: E* and the rows' pressures,
#: in Pa).
LARGE_STRAIN_NOTE = (
    "^ the nominal pressure of these rows ({rows} Pa) is at or above E* = {modulus} Pa: "
    "strains of order one, outside the linear-elastic contact model (small strains and "
    "slopes), so their a_c, gap and leak rate are not the seal's; seals run far below E* "
    "(check --modulus, the pair's contact modulus, and the unit of --pressures)")


def format_table(ds: xr.Dataset, rate_unit: str | None = None) -> str:
    """The leak curve of a (one-scan) leak dataset as a text table, its leak rates in
    ``rate_unit`` (a volume per time, :func:`roughflow.units.parse_rate_unit`; default: the
    dataset's own, m^3/s). Rows are marked after a_c where the analysed window holds no
    contact cell ("*") or too few to resolve the contact ("~"), where the fluid pressure
    is at or above the row's ("!") and where the row's is at or above E* ("^"), with a note
    under the table for each mark used (:func:`_row_flags`)."""
    import numpy as np

    from roughflow.units import parse_rate_unit

    stored = str(ds["leak_rate"].attrs["units"])
    unit = stored if rate_unit is None else str(rate_unit).strip()
    per_unit = (parse_rate_unit(stored, "the dataset's leak_rate units")
                / parse_rate_unit(unit, "rate_unit"))
    qw = max(10, len(unit))  # a long unit widens the leak-rate columns
    d = ds.isel(scan=0)
    flags = _row_flags(ds, d)
    marks = ["".join(m for m, rows in flags.items() if rows[i])
             for i in range(d.sizes["pressure"])]
    mw = max([1, *(len(m) for m in marks)])  # a row may carry several marks
    lines = [f"{d['scan'].item()}: boundary {ds.attrs['boundary']}, E* = "
             f"{ds.attrs['ref_pressure_Pa']:.4g} Pa, dp = {ds.attrs['fluid_pressure_Pa']:.4g} "
             f"Pa, eta = {ds.attrs['ref_viscosity_Pa_s']:.4g} Pa s, seal w = "
             f"{ds.attrs['seal_width_m']:.4g} m, l = {ds.attrs['seal_length_m']:.4g} m",
             f"{'p [Pa]':>10} {'a_c':>9}{'':{mw}} {'gap':>9} {'perc x':>6} {'perc y':>6} "
             f"{'sigma_x':>10} {'sigma_y':>10} {'Q_x':>{qw}} {'Q_y':>{qw}}",
             f"{'':>10} {'':>9}{'':{mw}} {'m':>9} {'':>6} {'':>6} {'m^3/(Pa s)':>10} "
             f"{'m^3/(Pa s)':>10} {unit:>{qw}} {unit:>{qw}}"]
    for i in range(d.sizes["pressure"]):
        r = d.isel(pressure=i)
        c, pc = r["conductance"].values, r["percolating"].values
        q = r["leak_rate"].values * per_unit
        # 4 significant digits, not decimals: a_c = 1e-5 and exactly 0 read apart
        lines.append(f"{float(r['pressure']):10.4g} {float(r['area_fraction']):9.4g}"
                     f"{marks[i]:{mw}} {_mean_gap_m(ds, r):9.3e} "
                     f"{'yes' if pc[0] else 'no':>6} {'yes' if pc[1] else 'no':>6} "
                     f"{c[0]:10.3e} {c[1]:10.3e} {q[0]:{qw}.3e} {q[1]:{qw}.3e}")
    lines += _sealing_lines(ds, d)
    lines += _contact_pressure_line(d)
    lines += _plastic_lines(ds)
    if flags["*"].any():
        lines.append(f"note: {EMPTY_WINDOW_NOTE}")
    if flags["~"].any():
        nx, ny = _window_shape(ds)
        lines.append(f"note: {FEW_CELLS_NOTE.format(nx=nx, ny=ny)}")
    p = np.asarray(d["pressure"].values, dtype=float)
    if flags["!"].any():
        lines.append("note: " + FLUID_LIFT_NOTE.format(
            fluid=f"{float(ds.attrs['fluid_pressure_Pa']):.4g}",
            rows=", ".join(f"{v:.4g}" for v in p[flags["!"]])))
    if flags["^"].any():
        lines.append("note: " + LARGE_STRAIN_NOTE.format(
            modulus=f"{float(ds.attrs['ref_pressure_Pa']):.4g}",
            rows=", ".join(f"{v:.4g}" for v in p[flags["^"]])))
    warned = str(ds.attrs.get("scan_warnings", ""))
    if warned:  # said in the import's log, which a workflow's user may never read
        lines.append(f"note: the import warned: {warned}")
    fluid_note = str(ds.attrs.get("fluid_pressure_note", ""))
    if fluid_note:
        lines.append(f"note: {fluid_note}")
    msg = ds.attrs.get("sealing_messages", "none")
    if msg != "none":
        lines.append(f"note: {msg}")
    return "\n".join(lines)


def _mean_gap_m(ds: xr.Dataset, row: xr.Dataset) -> float:
    """The mean gap of a row in metres (files written before ``mean_gap_si``: from the
    reference length)."""
    if "mean_gap_si" in row:
        return float(row["mean_gap_si"])
    return float(row["mean_gap"]) * float(ds.attrs["ref_length_m"])


def _plastic_lines(ds: xr.Dataset) -> list[str]:
    """With --hardness: the cap and the plastic share of each row's contact area (and that
    the sealing pressures are the capped contact's)."""
    if "hardness_Pa" not in ds.attrs:
        return []
    import numpy as np

    shares = ", ".join(f"{v:.4g}" for v in np.ravel(ds["plastic_fraction"].values))
    sealing = (" and of the sealing search" if ds.attrs.get("sealing_searched", 1) else "")
    return [f"hardness {float(ds.attrs['hardness_Pa']):.4g} Pa caps the contact pressure of "
            f"the rows{sealing} (elastic-perfectly-plastic); plastic area fraction per row: "
            f"{shares}"]


def _contact_pressure_line(d: xr.Dataset) -> list[str]:
    """The range of the mean pressure on the contacts, p / a_c, over the table's rows: the
    model is purely elastic, and the examples reach GPa, beyond most metals' hardness (a seal
    engineer has to compare; without --hardness nothing here knows the hardness)."""
    import numpy as np

    p = np.asarray(d["pressure"].values, dtype=float)
    a = np.asarray(d["area_fraction"].values, dtype=float)
    touching = np.isfinite(p) & np.isfinite(a) & (a > 0)
    if not touching.any():
        return []
    held = p[touching] / a[touching]
    if "hardness_Pa" in d.attrs:
        # the local pressure is at most the hardness, but the mean over a window's contact
        # is not the cell's (the window's share of the load is not its share of the area)
        return [f"mean pressure on the contacts p/a_c: {held.min():.3g} - {held.max():.3g} "
                f"Pa (local pressures capped at the hardness "
                f"{float(d.attrs['hardness_Pa']):.4g} Pa)"]
    return [f"mean pressure on the contacts p/a_c: {held.min():.3g} - {held.max():.3g} Pa "
            "(the model is purely elastic: where this exceeds the softer face's hardness, "
            "the faces yield)"]


def _window_shape(ds: xr.Dataset) -> tuple[int, int]:
    """The analysed window's cells along x and y."""
    return int(ds.attrs["window_nx"]), int(ds.attrs["window_ny"])


def _row_flags(ds: xr.Dataset, d: xr.Dataset) -> dict[str, np.ndarray]:
    """Per mark of the table, in the order a row shows them, its rows of the one-scan
    dataset ``d``: "*" where the analysed window holds no contact cell
    (:func:`roughflow.leak.empty_window_rows`), "~" where it holds too few to resolve the
    contact (:func:`roughflow.leak.few_cell_rows`), "!" where the fluid pressure is at or
    above the row's (:func:`roughflow.leak.fluid_lifted_rows`), "^" where the row's is at or
    above E* (:func:`roughflow.leak.large_strain`)."""
    import numpy as np

    from roughflow.leak import empty_window_rows, few_cell_rows, fluid_lifted_rows, large_strain

    area = d["area_fraction"].values
    p = np.asarray(d["pressure"].values, dtype=float)
    return {"*": empty_window_rows(area), "~": few_cell_rows(area, _window_shape(ds)),
            "!": fluid_lifted_rows(p, float(ds.attrs["fluid_pressure_Pa"])),
            "^": large_strain(p / float(ds.attrs["ref_pressure_Pa"]))}


def _sealing_lines(ds: xr.Dataset, d: xr.Dataset) -> list[str]:
    """The sealing pressure along x and y, each with a caveat where it is not above the
    fluid pressure, the note on a seal that closes only at a large a_c*, and the note on
    one at or above E* (:func:`roughflow.leak.large_strain`)."""
    from roughflow.leak import large_strain

    if not ds.attrs.get("sealing_searched", 1):
        return ["sealing pressure: not searched (--no-sealing)"]
    fluid = float(ds.attrs["fluid_pressure_Pa"])
    modulus = float(ds.attrs["ref_pressure_Pa"])
    lines = []
    for k, a in enumerate(("x", "y")):
        lo, hi = (float(d[v].values[k]) for v in ("sealing_pressure_lo", "sealing_pressure"))
        star = float(d["a_c_star"].values[k])
        # a seal that closes at a contact pressure the fluid's pressure exceeds would be
        # lifted open by it: the model, which leaves the fluid's load out, cannot say
        caveat = (f"; not above the fluid pressure {fluid:.4g} Pa, which would lift the faces "
                  "apart: outside the model's assumptions (dp << p)" if lo <= fluid else "")
        lines.append(f"sealing pressure along {a}: between {lo:.4g} Pa and {hi:.4g} Pa "
                     f"(a_c* = {star:.4f}){caveat}")
    for k, a in enumerate(("x", "y")):
        star = float(d["a_c_star"].values[k])
        if star > SEALING_AREA_NOTE:
            lines.append(f"note: along {a} the seal closes only at a_c* = {star:.3f} (random "
                         f"surfaces: about 0.4): a channel the contact hardly closes, such as "
                         f"one scan line offset from the others (compare an import with "
                         f"--detrend lines-x or lines-y) or a large region filled with "
                         f"--fill min (a flat basin)")
        lo, hi = (float(d[v].values[k]) for v in ("sealing_pressure_lo", "sealing_pressure"))
        if large_strain(hi / modulus):  # the seal closes there or above, if at all
            lines.append(f"note: the sealing pressure along {a} (between {lo:.4g} Pa and "
                         f"{hi:.4g} Pa) is at or above E* = {modulus:.4g} Pa: strains of order "
                         "one, outside the linear-elastic contact model (small strains and "
                         "slopes), which does not tell whether the seal closes there")
    return lines
