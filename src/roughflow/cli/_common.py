"""The shared input/output layer of the subcommands.

A subcommand declares its files with :func:`add_input` (a dataset of given kinds,
:mod:`roughflow.datasets.kinds`) and :func:`add_output` (or :func:`add_output_folder`, a
folder of files with fixed names); before its ``func`` runs,
:func:`roughflow.cli.main` checks every output path (:func:`roughflow.io.check_output`:
writable, not a directory, the right suffix) and reads every input (:func:`read_inputs`:
readable netCDF of the expected kind, loaded into ``args.data[dest]``). Any failure is an
:class:`~roughflow.errors.InputError`: exit status 2 with a message naming the file, before
any work starts. A new subcommand gets all of this by using the two helpers.
"""

from __future__ import annotations

import argparse
import logging
import math
from collections.abc import Callable
from pathlib import Path

from roughflow import defaults
from roughflow.errors import InputError

#: Namespace attributes where the helpers record what to check (set with set_defaults).
_OUTPUTS = "_outputs"
_OUTPUT_FOLDERS = "_output_folders"
_INPUTS = "_inputs"
_SOURCES = "_sources"

AXES = {"x": 0, "y": 1, "both": None}
#: The unit of every dimensionless pressure option: E* with lengths in units of the cell side
#: L. That is E* gbar only for a generated surface (rms gradient gbar = 1); an imported scan
#: keeps its gradient (docs/measured.md).
PRESSURE_UNIT = "E* (E* gbar for a generated surface, rms gradient gbar 1; a scan keeps its gbar)"

#: The sweep's surface options: flag -> (type, default, help). Defaults from
#: roughflow.defaults; L / lambda_r None means the paper's size.
SURFACE_OPTIONS = {
    "--gamma": (float, defaults.GAMMA, "Peklenik number; > 1 stretches along x"),
    "--hurst": (float, defaults.HURST, "Hurst exponent H in (0, 1]"),
    "--l-over-lambda-r": (float, None, "L / lambda_r"),
    "--eps-f": (float, defaults.EPS_F, "lambda_s / lambda_r"),
    "--points-per-lambda-s": (float, defaults.POINTS_PER_LAMBDA_S,
                              "grid points per shortest wavelength"),
    "--aspect": (float, defaults.ASPECT, "lx / ly of a unit-area cell"),
    "--rolloff": (str, defaults.ROLLOFF_FORMS[0], "roll-off form of the spectrum"),
}
#: What a default of None means, for the help of the options that have one.
_NONE_DEFAULTS = {"--l-over-lambda-r": "the paper's 4 max(sqrt(gamma), 1/sqrt(gamma))"}


def _record(parser: argparse.ArgumentParser, attr: str, entry: tuple) -> None:
    parser.set_defaults(**{attr: [*(parser.get_default(attr) or []), entry]})


def add_output(parser: argparse.ArgumentParser, *flags: str, dest: str = "output",
               suffixes: tuple[str, ...] = (".nc",), required: bool = True,
               metavar: str = "FILE.nc", help: str = "netCDF file to write") -> None:
    """An output file option (default ``-o/--output``), checked by :func:`roughflow.io.check_output`
    before the subcommand runs."""
    flags = flags or ("-o", "--output")
    parser.add_argument(*flags, dest=dest, required=required, default=None, metavar=metavar,
                        help=help)
    _record(parser, _OUTPUTS, (dest, flags[-1], tuple(suffixes)))


def add_output_folder(parser: argparse.ArgumentParser, flag: str, *, default: str,
                      files: Callable[[argparse.Namespace], list[str]], help: str) -> None:
    """An output folder option, in which the subcommand writes the files ``files(args)``
    (names inside the folder); each is checked by :func:`roughflow.io.check_output` before
    the subcommand runs, as an :func:`add_output` file is."""
    parser.add_argument(flag, default=default, metavar="DIR", help=f"{help} ({default})")
    _record(parser, _OUTPUT_FOLDERS, (dest_of(flag), flag, files))


def add_input(parser: argparse.ArgumentParser, *names: str, kinds: str | tuple[str, ...] | None,
              what: str, **kwargs) -> None:
    """An input file (positional ``names[0]``, or an option), read by :func:`read_inputs`
    before the subcommand runs: ``args.data[dest]`` holds the dataset (a list for
    ``nargs``, None when an optional input is not given). ``kinds`` None: any dataset (the
    subcommand checks the kind itself)."""
    action = parser.add_argument(*names, **kwargs)
    _record(parser, _INPUTS, (action.dest, kinds, what))


def dest_of(flag: str) -> str:
    """The namespace attribute of a long option (``--eps-f`` -> ``eps_f``)."""
    return flag[2:].replace("-", "_")


# Refusing a given option that does not apply: argparse cannot tell a given option from its
# default by the value alone.
class _RecordGiven(argparse.Action):
    """argparse's plain store action that also records that its option was given, in
    ``args._given`` (the defaults stay the documented values, so a value equal to the
    default still counts as given)."""

    def __call__(self, parser, namespace, values, option_string=None) -> None:
        setattr(namespace, self.dest, values)
        if option_string is not None:
            namespace._given = {*getattr(namespace, "_given", ()), self.dest}


def track_given(parser: argparse.ArgumentParser) -> None:
    """Make every plain option added to ``parser`` from now on record whether it was given
    (:func:`given`), so that a command can refuse a given option that does not apply."""
    parser.register("action", None, _RecordGiven)


def given(args: argparse.Namespace) -> set[str]:
    """Destinations of the options given on the command line (:func:`track_given`)."""
    return set(getattr(args, "_given", ()))


def refuse_given(args: argparse.Namespace, flags: tuple[str, ...], why: str) -> None:
    """InputError naming those of ``flags`` that were given, with their values, and ``why``
    they do not apply."""
    named = [f"{f} {getattr(args, dest_of(f))}" for f in flags if dest_of(f) in given(args)]
    if named:
        raise InputError(f"{', '.join(named)}: {'does' if len(named) == 1 else 'do'} not "
                         f"apply {why}")


def add_source(parser: argparse.ArgumentParser, dest: str) -> None:
    """Declare the argument ``dest`` a file the subcommand reads itself (not a dataset read
    by :func:`read_inputs`), so that no output may replace it."""
    _record(parser, _SOURCES, dest)


def _paths(value) -> list[str]:
    return [] if value is None else [str(v) for v in value] if isinstance(value, list) \
        else [str(value)]


def check_outputs(args: argparse.Namespace) -> None:
    """:func:`roughflow.io.check_output` for every output the subcommand declared (given
    ones only), and none may be one of the command's input files (``roughflow import
    scan.nc -o scan.nc`` replaced the measurement with its import)."""
    from roughflow.io import check_output

    sources = [*(e[0] for e in getattr(args, _INPUTS, None) or []),
               *(getattr(args, _SOURCES, None) or [])]
    inputs = [Path(v) for dest in sources for v in _paths(getattr(args, dest, None))]
    for dest, option, suffixes in getattr(args, _OUTPUTS, None) or []:
        out = getattr(args, dest, None)
        if out is None:
            continue
        check_output(out, option=option, suffixes=suffixes)
        for source in inputs:
            if Path(out).absolute() == source.absolute() or (
                    Path(out).exists() and source.exists() and Path(out).samefile(source)):
                raise InputError(f"{option} {str(out)!r} is also an input of the command: "
                                 "writing it would replace that file; give another name")
    for dest, option, files in getattr(args, _OUTPUT_FOLDERS, None) or []:
        folder = Path(getattr(args, dest))
        if folder.exists() and not folder.is_dir():
            raise InputError(f"{option} {str(folder)!r} is a file; give a folder")
        for name in files(args):
            check_output(folder / name, option=option, suffixes=(Path(name).suffix,))


def read_inputs(args: argparse.Namespace) -> None:
    """Read every input the subcommand declared into ``args.data`` (by destination)."""
    from roughflow.io import read_dataset

    args.data = {}
    for dest, kinds, what in getattr(args, _INPUTS, None) or []:
        value = getattr(args, dest, None)
        if value is None:
            args.data[dest] = None
        elif isinstance(value, list):
            args.data[dest] = [read_dataset(v, kinds, what=what) for v in value]
        else:
            args.data[dest] = read_dataset(value, kinds, what=what)


def warn_if_nonperiodic_scan(ds, source: str, command: str, treat: str | None = None) -> None:
    """Warn that ``command`` solves the measured scan of dataset ``ds`` (a surface file or a
    contact file made from one, with the scan's ``scan_periodic`` attribute) as a periodic
    cell when the scan is not periodic; ``treat``: the command's own option that treats
    the edges (else only ``roughflow leak`` does)."""
    periodic = ds.attrs.get("scan_periodic")
    if periodic is None or bool(periodic):
        return
    how = (f"`roughflow {command} {treat} {defaults.BOUNDARY}` treats the edges as "
           "`roughflow leak` does" if treat else
           f"`roughflow leak` treats the edges (--boundary, default {defaults.BOUNDARY})")
    logging.getLogger("roughflow.cli").warning(
        "%s holds a non-periodic scan: `roughflow %s` solves it as a periodic cell, whose "
        "wrap-around joins opposite edges with a step (on test windows that moved a_c* by "
        "0.05 and ln sigma by 0.45 rms, docs/measured.md, 'Non-periodic scans'); %s",
        source, command, how)


def number_or_quantity(text: str) -> float | str:
    """A pressure option's value: a number (in E*), else the text of a quantity with its
    unit (400MPa), converted with the modulus by :func:`pressure_in_e_star`."""
    try:
        return float(text)
    except ValueError:
        return text


def pressure_in_e_star(value: float | str | None, modulus: float | None,
                       flag: str) -> float | None:
    """A pressure option ``flag`` (:func:`number_or_quantity`) in E*: a number is in E*
    (refused next to ``--modulus``, which asks for units, except zero, zero in any unit), a
    quantity is divided by ``modulus`` (Pa; refused without one) and keeps its sign (a
    tension of the adhesive model). None stays None."""
    from roughflow.units import parse_quantity

    if value is None:
        return None
    if isinstance(value, str):
        if modulus is None:
            raise InputError(f"{flag} {value!r} has a unit: give --modulus (the pair's "
                             "contact modulus E*, e.g. 200GPa) to express it in E*")
        text = value.strip()  # parse_quantity takes magnitudes
        sign = -1.0 if text.startswith("-") else 1.0
        return sign * parse_quantity(text.lstrip("+-"), "pressure", flag) / modulus
    if modulus is not None and value != 0:
        raise InputError(f"{flag} {value!r} is a number in E*, but --modulus asks for "
                         "pressures with their unit: give it with its unit (e.g. 400MPa), or "
                         "leave --modulus out")
    return value


def require_resolved_pressure(option: str, pressure: float, floor: float, modulus: str,
                              shape: tuple[int, int], gbar: float) -> None:
    """Refuse the pressure ``option`` (its lowest value ``pressure``, Pa) below ``floor``
    (Pa), the lowest the ``shape`` grid of rms gradient ``gbar`` resolves (the library's
    :func:`~roughflow.contact.solve.resolved_load_floor` times E*, the ``--modulus``
    as given), in the options' words; the library refuses it too, in E*."""
    if pressure < floor:
        raise InputError(
            f"{option} {pressure:.4g} Pa is below what the {shape[0]} x {shape[1]} grid "
            f"resolves: {floor:.3g} Pa for its rms gradient {gbar:.3g} and --modulus "
            f"{modulus} (the elastic law puts {defaults.CONTACT_MIN_CELLS:g} of one cell in "
            "contact there; below, the contact is a single cell and the solver's load "
            f"balance reaches round-off); give {option} of {floor:.3g} Pa or more")


def hardness_in_e_star(value: float | str | None, modulus: float | None) -> float | None:
    """--hardness (:func:`number_or_quantity`) in E*, as :func:`pressure_in_e_star`, refused
    unless positive, finite and at most ``CONTACT_PRESSURE_MAX`` E* (a larger one is a
    hardness in pascals given as a number)."""
    hardness = pressure_in_e_star(value, modulus, "--hardness")
    if hardness is None:
        return None
    if not (math.isfinite(hardness) and hardness > 0):  # nan, inf, zero or a tension
        raise InputError(f"--hardness must be a positive, finite pressure, got {value}")
    if hardness > defaults.CONTACT_PRESSURE_MAX:
        raise InputError(f"--hardness {value} is {hardness:g} E*, above "
                         f"{defaults.CONTACT_PRESSURE_MAX:g} E*: give it in E*, or with its "
                         "unit and --modulus (e.g. --hardness 2GPa --modulus 200GPa)")
    return hardness


def add_backend(parser: argparse.ArgumentParser) -> None:
    """``--backend {cpu,cupy}``: where the elastic gfmd solves run (``roughflow.gpu``)."""
    parser.add_argument("--backend", choices=defaults.BACKENDS, default=defaults.DEFAULT_BACKEND,
                        help="cpu, or cupy: the elastic gfmd solves on a CUDA GPU (needs CuPy: "
                             "roughflow[gpu]) (cpu)")


def on_backend(args: argparse.Namespace) -> None:
    """Check ``--backend`` (CuPy and a GPU) before any work and record it in
    ``args.provenance``."""
    from dataclasses import replace

    from roughflow.gpu import describe

    args.provenance = replace(args.provenance, backend=describe(args.backend))


def axis_arg(value: str) -> int | None:
    """Parse ``x``, ``y`` or ``both`` into 0, 1 or None."""
    if value not in AXES:
        raise argparse.ArgumentTypeError(f"axis must be x, y or both, got {value!r}")
    return AXES[value]


def add_surface_options(group, flags=tuple(SURFACE_OPTIONS), **overrides) -> None:
    """Add the sweep's surface options ``flags`` (:data:`SURFACE_OPTIONS`) to ``group``;
    ``overrides`` maps a destination name to another default."""
    for flag in flags:
        kind, default, text = SURFACE_OPTIONS[flag]
        dest = dest_of(flag)
        default = overrides.get(dest, default)
        extra = {"choices": defaults.ROLLOFF_FORMS} if flag == "--rolloff" else {"type": kind}
        shown = (f" (default: {_NONE_DEFAULTS[flag]})" if default is None
                 else f" ({default:g})" if kind is float else f" ({default})")
        group.add_argument(flag, default=default, help=text + shown, **extra)


def add_repulsion(p: argparse.ArgumentParser) -> None:
    """The adhesive model's ``--repulsion`` option (contact, threshold, scene ladder)."""
    p.add_argument("--repulsion", choices=defaults.ADHESION_REPULSIONS, default=None,
                   help="adhesive model: the wall under the cosine attraction (default "
                        f"{defaults.ADHESION_REPULSION}; docs/contact.md \"Adhesion\")")


def resolve_adhesion(model: str, surface_energy: float | None, adhesion_range: float | None,
                     surface, *, flags: tuple[str, str], source: str,
                     repulsion: str | None = None):
    """The :class:`~roughflow.contact.Adhesion` of ``--model adhesive`` (None for the other
    models) on the ``repulsion`` wall (None: ``ADHESION_REPULSION``): both values given, or
    neither for the paper's adhesive case (gamma_s = ``ADHESION_SURFACE_ENERGY_RATIO``
    v_ela^full, rho = ``ADHESION_RANGE_OVER_LAMBDA_S[repulsion]`` lambda_s of the surface
    file's spec). ``flags`` name the two options in errors, ``source`` the surface file."""
    from roughflow.contact import Adhesion
    from roughflow.contact.adhesion import adhesion_for

    given = (surface_energy, adhesion_range)
    both = " and ".join(flags)
    if model != "adhesive":
        if any(v is not None for v in given) or repulsion is not None:
            raise InputError(f"{both} and --repulsion are only for --model adhesive")
        return None
    repulsion = defaults.ADHESION_REPULSION if repulsion is None else repulsion
    if all(v is None for v in given):
        if surface.spec is None:
            raise InputError(f"{source} records no lambda_s (not written by roughflow "
                             f"surface): give {both}")
        rho = defaults.ADHESION_RANGE_OVER_LAMBDA_S[repulsion] * surface.spec.lambda_s
        return adhesion_for(surface.heights, surface.lx, surface.ly,
                            gamma_over_v_full=defaults.ADHESION_SURFACE_ENERGY_RATIO,
                            range=rho, repulsion=repulsion)
    if any(v is None for v in given):
        raise InputError(f"--model adhesive needs both {both} (or neither, for the paper's "
                         "adhesive case)")
    return Adhesion(surface_energy=surface_energy, range=adhesion_range, repulsion=repulsion)


def adhesion_help(what: str) -> str:
    """Help of the surface-energy option: the default when neither value is given."""
    ranges = ", ".join(f"{v} ({k})" for k, v in defaults.ADHESION_RANGE_OVER_LAMBDA_S.items())
    return (f"adhesive model: {what}; without both adhesion options: the paper's adhesive "
            f"case, gamma_s = {defaults.ADHESION_SURFACE_ENERGY_RATIO} v_ela^full and rho = "
            f"{ranges} lambda_s for the --repulsion (needs a surface file written by "
            "roughflow surface, which records lambda_s). Calibrated on the paper's Fig. 5 "
            "surface (H 0.8, eps_f 1/16): rho follows lambda_s, not the rms height, so on "
            "other spectra the same values give other areas (docs/contact.md 'Adhesion')")

