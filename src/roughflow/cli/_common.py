"""Argument helpers shared by the subcommands."""

from __future__ import annotations

import argparse

from roughflow import defaults

AXES = {"x": 0, "y": 1, "both": None}

#: The sweep's surface options: flag -> (type, default, help). Defaults from
#: roughflow.defaults; L / lambda_r None means the paper's size.
SURFACE_OPTIONS = {
    "--gamma": (float, defaults.GAMMA, "Peklenik number; > 1 stretches along x"),
    "--hurst": (float, defaults.HURST, "Hurst exponent H in (0, 1]"),
    "--l-over-lambda-r": (float, None, "L / lambda_r (default: the paper's "
                                       "4 max(sqrt(gamma), 1/sqrt(gamma)))"),
    "--eps-f": (float, defaults.EPS_F, "lambda_s / lambda_r"),
    "--points-per-lambda-s": (float, defaults.POINTS_PER_LAMBDA_S,
                              "grid points per shortest wavelength"),
    "--aspect": (float, defaults.ASPECT, "lx / ly of a unit-area cell"),
    "--rolloff": (str, defaults.ROLLOFF_FORMS[0], "roll-off form of the spectrum"),
}


def add_output(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "-o", "--output", required=True, metavar="FILE.nc", help="netCDF file to write"
    )


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
        dest = flag[2:].replace("-", "_")
        default = overrides.get(dest, default)
        extra = {"choices": defaults.ROLLOFF_FORMS} if flag == "--rolloff" else {"type": kind}
        shown = "" if default is None else f" ({default:g})" if kind is float else f" ({default})"
        group.add_argument(flag, default=default, help=text + shown, **extra)
