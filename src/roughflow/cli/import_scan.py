"""``roughflow import``: read a measured scan into a roughflow surface file."""

from __future__ import annotations

import argparse

from roughflow.defaults import (
    DETREND_MODES,
    FILL_METHODS,
    SCAN_CROP_DEFINED,
    SCAN_DETREND,
    SCAN_FILL,
)

from ._common import add_output, add_source


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "import",
        help="read a measured topography (AFM, profilometer, ...) into a surface file",
        description=(
            "Read a measured scan in any format SurfaceTopography reads (pip install "
            "'roughflow[topography]'), crop, detrend and fill it, and write a surface file "
            "for `roughflow leak` (and the other commands). Heights and lengths are stored "
            "in units of L = sqrt(lx ly) of the scan; L in metres, the scan's rms gradient, "
            "the reader, the detrending and the number of filled points are attributes. "
            "Options the file already gives (size, unit) are refused."
        ),
    )
    p.add_argument("scan", metavar="SCAN", help="scan file (instrument format, .nc, .npy, "
                                                "text, ...)")
    p.add_argument("--size", default=None, metavar="LX[,LY]",
                   help="physical size where the file gives none, e.g. 500nm or "
                        "0.126mm,0.094mm (numbers alone are in --unit)")
    p.add_argument("--unit", default=None,
                   help="length unit of the file's sizes and heights where it gives none "
                        "(e.g. nm, um, mm)")
    p.add_argument("--height-unit", default=None,
                   help="unit of the heights where the file gives none and it differs from "
                        "--unit")
    p.add_argument("--detrend", choices=DETREND_MODES, default=SCAN_DETREND,
                   help="remove a fitted plane or plane + quadratic, or level the scan "
                        "lines along x or y (mean and tilt of each line: line-to-line "
                        f"offsets of AFM scans) ({SCAN_DETREND})")
    p.add_argument("--fill", choices=FILL_METHODS, default=SCAN_FILL,
                   help="missing points: none refuses a scan that has any; harmonic "
                        "(Laplace interpolation) or min (lowest height: open, conservative "
                        f"for leaks) ({SCAN_FILL})")
    p.add_argument("--crop", default=None, metavar="I0:I1,J0:J1|defined",
                   help="keep this grid window (Python slices along x and y), e.g. to cut a "
                        f"border of missing points; {SCAN_CROP_DEFINED}: the largest window "
                        "without missing points")
    p.add_argument("--channel", default=None,
                   help="data channel by name or index (default: the file's height "
                        "channel, with a warning where another channel has its name)")
    p.add_argument("--missing-value", type=float, default=None, metavar="V",
                   help="the number that marks missing points in the file (an instrument's "
                        "placeholder such as -999999 or 1e38; nan always counts); write a "
                        "negative one with '=': --missing-value=-1e38")
    p.add_argument("--periodic", action="store_true",
                   help="the scan is periodic (e.g. simulated): no boundary treatment later")
    add_source(p, "scan")
    add_output(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> None:
    from roughflow.io import surface_to_dataset, write_dataset
    from roughflow.scan import read_scan

    surface = read_scan(args.scan, size=args.size, unit=args.unit,
                        height_unit=args.height_unit, detrend_mode=args.detrend,
                        fill=args.fill, crop=args.crop, channel=args.channel,
                        periodic=args.periodic, missing_value=args.missing_value)
    write_dataset(surface_to_dataset(surface), args.output, provenance=args.provenance)
    s = surface.scan
    nx, ny = surface.shape
    print(f"{args.scan}: {s.reader}, channel {s.channel}, {nx} x {ny} points, "
          f"{surface.lx * s.length_scale:.4g} m x {surface.ly * s.length_scale:.4g} m, "
          f"rms height {surface.heights.std() * s.length_scale:.4g} m, rms gradient "
          f"{s.rms_gradient:.4g}, detrend {s.detrend}, {s.filled} "
          f"point{'' if s.filled == 1 else 's'} filled ({s.fill})"
          + ("" if s.crop == "none" else f", crop {s.crop}"))
