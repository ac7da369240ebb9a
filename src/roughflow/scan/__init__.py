"""Measured topographies: reading scans into dimensionless :class:`~roughflow.surface.Surface`s.

:func:`read_scan` reads every format that SurfaceTopography reads (the optional extra
``pip install roughflow[topography]``, imported here only) and prepares the heights in this
order: crop to a grid window, convert to metres, detrend (fitted to the defined points),
fill missing points (a scan with missing points is refused unless a fill is chosen), and
scale to the dimensionless system: lengths in units of L = sqrt(lx ly) of the scan, whose
value in metres is ``ScanInfo.length_scale``. The scan keeps its own rms gradient, so its
pressures are in units of E* (not E* gbar).

The array helpers (:func:`detrend`, :func:`level_lines`, :func:`fill_missing`,
:func:`largest_defined_window`) work on plain numpy arrays.

Submodules: :mod:`roughflow.scan.prepare` (the array helpers) and :mod:`roughflow.scan.read`
(reading: formats, channels, crop, units; :func:`read_scan`).
"""

from __future__ import annotations

from .prepare import detrend, fill_missing, largest_defined_window, level_lines
from .read import (
    HEIGHT_CHANNEL_NAMES,
    MISSING_VALUE_RTOL,
    TEXT_SUFFIXES,
    check_crop,
    is_number,
    length_factor,
    parse_crop,
    read_scan,
    scan_size,
)

__all__ = ["detrend", "level_lines", "fill_missing", "largest_defined_window", "check_crop",
           "parse_crop", "length_factor", "scan_size", "is_number", "TEXT_SUFFIXES",
           "HEIGHT_CHANNEL_NAMES", "MISSING_VALUE_RTOL", "read_scan"]
