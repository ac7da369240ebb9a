"""Argument helpers shared by the subcommands."""

from __future__ import annotations

import argparse

AXES = {"x": 0, "y": 1, "both": None}


def add_output(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "-o", "--output", required=True, metavar="FILE.nc", help="netCDF file to write"
    )


def axis_arg(value: str) -> int | None:
    """Parse ``x``, ``y`` or ``both`` into 0, 1 or None."""
    if value not in AXES:
        raise argparse.ArgumentTypeError(f"axis must be x, y or both, got {value!r}")
    return AXES[value]
