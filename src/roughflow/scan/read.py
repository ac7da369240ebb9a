"""Reading measured scans (:func:`read_scan`): format detection and SurfaceTopography's
readers (the optional extra ``pip install roughflow[topography]``, imported here only), the
data channel, the crop window, units and size; the heights are then prepared with the array
helpers of :mod:`roughflow.scan.prepare` and scaled to the dimensionless system.
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import math
import os
import re
import warnings
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from roughflow.defaults import (
    DETREND_MODES,
    FILL_METHODS,
    SCAN_CROP_DEFINED,
    SCAN_DETREND,
    SCAN_FILL,
    SCAN_FILL_WARN_FRACTION,
    SCAN_FLAT_RELATIVE,
    SCAN_GRADIENT_WARN,
    SCAN_PIXEL_ASPECT_WARN,
    SCAN_READER,
    SCAN_READER_EXTRA,
)
from roughflow.errors import InputError, require_installed
from roughflow.files import require_readable
from roughflow.surface import ScanInfo, Surface, rms_gradient

from .prepare import detrend, fill_missing, largest_defined_window

if TYPE_CHECKING:
    from collections.abc import Sequence

__all__ = ["check_crop", "parse_crop", "length_factor", "scan_size", "is_number",
           "TEXT_SUFFIXES", "HEIGHT_CHANNEL_NAMES", "MISSING_VALUE_RTOL", "read_scan"]

#: The package's logger, as before the module was split: its name is in every log line.
log = logging.getLogger("roughflow.scan")


def _window_text(window: tuple[slice, slice], shape: tuple[int, int]) -> str:
    """A window as the crop text "i0:i1,j0:j1" with both ends of each slice."""
    (i0, i1, _), (j0, j1, _) = (w.indices(n) for w, n in zip(window, shape, strict=True))
    return f"{i0}:{i1},{j0}:{j1}"


def _defined_window_hint(missing: np.ndarray, window: tuple[slice, slice] | None,
                         shape: tuple[int, int]) -> str:
    """Where the largest window without missing points lies (in the file's grid indices;
    ``missing`` is the mask inside ``window`` of a scan of ``shape``), for messages."""
    sx, sy = largest_defined_window(missing)
    i0, j0 = (0, 0) if window is None else (window[0].indices(shape[0])[0],
                                            window[1].indices(shape[1])[0])
    nx, ny = sx.stop - sx.start, sy.stop - sy.start
    where = _window_text((slice(sx.start + i0, sx.stop + i0),
                          slice(sy.start + j0, sy.stop + j0)), shape)
    how = (f"; crop={SCAN_CROP_DEFINED!r} (CLI --crop {SCAN_CROP_DEFINED}) keeps it"
           if window is None else "")
    return (f"the largest window without missing points is {where} ({nx} x {ny} points, "
            f"{100 * nx * ny / missing.size:.3g} % of the points{how})")


_CROP = re.compile(r"^\s*(\d*)\s*:\s*(\d*)\s*,\s*(\d*)\s*:\s*(\d*)\s*$")


def check_crop(text: str | None) -> re.Match | None:
    """The syntax of a crop: None, "none", "defined" (None returned) or "i0:i1,j0:j1"
    (its match returned); anything else raises :class:`InputError` naming it."""
    if text is None or str(text).strip() in ("none", SCAN_CROP_DEFINED):
        return None
    m = _CROP.match(str(text))
    if m is None:
        raise InputError(f"crop must look like 'i0:i1,j0:j1' (grid indices) or be "
                         f"{SCAN_CROP_DEFINED!r}, got {text!r}")
    return m


def parse_crop(text: str | None, shape: tuple[int, int]) -> tuple[slice, slice] | None:
    """Grid window "i0:i1,j0:j1" (Python slices, ends may be left out) -> slices.
    (``"defined"`` is resolved by :func:`read_scan`, which knows the missing points.)"""
    m = check_crop(text)
    if m is None:
        return None
    v = [int(g) if g else None for g in m.groups()]
    for name, (lo, hi), n in zip("xy", (v[:2], v[2:]), shape, strict=True):
        # a slice would clamp an end past the grid, and the user would get a smaller window
        # than asked for without a word
        beyond = [e for e in (lo, hi) if e is not None and e > n]
        if beyond:
            raise InputError(f"crop {text!r} reaches index {beyond[-1]} along {name}, but "
                             f"the scan has {n} points there (indices 0:{n})")
    sx, sy = slice(v[0], v[1]), slice(v[2], v[3])
    _check_window((sx, sy), shape, f"crop {text!r}")
    return sx, sy


def _check_window(window: tuple[slice, slice], shape: tuple[int, int], what: str) -> None:
    nx, ny = (len(range(*w.indices(n))) for w, n in zip(window, shape, strict=True))
    if nx < 4 or ny < 4:
        raise InputError(f"{what} leaves {nx} x {ny} points of the {shape[0]} x "
                         f"{shape[1]} scan; at least 4 x 4 are needed")


def length_factor(unit: str, name: str) -> float:
    """Metres per ``unit`` (a pint-readable length unit such as "nm", "um", "mm")."""
    from roughflow.units import parse_quantity

    return parse_quantity(f"1 {unit}", "length", name)


def scan_size(size: str | float | Sequence[str | float], unit: str | None) -> tuple[float, float]:
    """Physical size (metres) from ``size``: a length or a pair (quantities with units, or
    numbers in ``unit``)."""
    from roughflow.units import parse_quantity

    parts = _size_parts(size)
    if len(parts) == 1:
        parts = parts * 2
    if len(parts) != 2:
        raise InputError(f"size must be one length or two (lx, ly), got {size!r}")
    out = []
    for p in parts:
        try:
            number = float(p)
        except (TypeError, ValueError):
            number = None
        if number is not None:
            if unit is None:
                raise InputError(f"size {size!r} has no unit: give one (e.g. '500nm') or unit=")
            p = f"{number!r} {unit}"
        out.append(parse_quantity(p, "length", "size"))
    return out[0], out[1]


def _size_parts(size: str | float | Sequence[str | float]) -> list:
    """The lengths ``size`` gives: one (both sides) or two (lx, ly)."""
    return list(size) if isinstance(size, (tuple, list)) else str(size).split(",")


def _has_bare_number(size: str | float | Sequence[str | float]) -> bool:
    """Whether ``size`` holds a number without a unit (which ``unit=`` then gives)."""
    return any(is_number(str(p).strip()) for p in _size_parts(size))


def _missing_unit(size) -> str:
    """What a scan that gives no unit lacks, for :func:`read_scan`'s refusal. A size with
    its units fixes the lateral one, so only the heights' unit is missing then: blaming
    "its length unit" misled a user who had just given ``--size 500nm``. Worded for the
    API's keywords and the command line's options alike."""
    if size is not None and not _has_bare_number(size):
        return (f"the unit of its heights (the size {size!r} gives only the lateral one): "
                "pass it as unit= or height_unit= (CLI --unit or --height-unit), e.g. 'nm'")
    return ("its length unit, of the heights and sizes: pass unit= (CLI --unit), e.g. 'nm', "
            "and height_unit= (CLI --height-unit) where the heights' unit differs")


def _lateral_units(size, unit: str | None) -> str:
    """How the lateral sizes were read, for messages: in ``unit``, or as ``size`` gave
    them with their own units."""
    if size is None or _has_bare_number(size):
        return f"in {unit}"
    return f"as given ({size!r})"


def _check_npy_complete(path: Path) -> None:
    """Refuse a .npy file shorter than its header says: SurfaceTopography maps such a file
    and reads whatever memory lies past its end (measured: a different map on every run)."""
    from numpy.lib import format as npy

    with path.open("rb") as fh:
        try:
            major, _ = npy.read_magic(fh)
            header = npy.read_array_header_1_0 if major == 1 else npy.read_array_header_2_0
            shape, _, dtype = header(fh)
        except ValueError as exc:
            raise InputError(f"{str(path)!r} is not a valid .npy file ({exc})") from None
        need = fh.tell() + math.prod(shape) * dtype.itemsize
    have = path.stat().st_size
    if have < need:
        raise InputError(f"{str(path)!r} is truncated: its header announces a {shape} "
                         f"{dtype} array ({need} bytes with the header), the file has {have}")


def is_number(token: str) -> bool:
    """Whether ``token`` reads as a float."""
    try:
        float(token)
    except ValueError:
        return False
    return True


def _check_text_complete(path: Path, shape: tuple[int, int]) -> None:
    """Refuse a plain-text matrix whose reader dropped lines: SurfaceTopography's text
    reader skips a line with a token it cannot read as a number (a "-", "NA" or "***" that
    marks a missing point) and reads the rest as a scan with one line fewer, every later
    line moved by one and the size spread over fewer pixels (measured: 128 x 127 points
    from 128 lines, no warning). A line of the matrix is one with as many values as the
    scan's lines have (``shape[0]``); the reader kept ``shape[1]`` of them."""
    nx, ny = shape
    rows, dropped = 0, []
    with path.open(encoding="utf-8", errors="replace") as fh:
        for number, line in enumerate(fh, 1):
            if line.lstrip().startswith("#"):
                continue
            tokens = re.split(r"[\s,;]+", line.strip())
            if len(tokens) != nx:
                continue
            bad = [t for t in tokens if not is_number(t)]
            if 2 * len(bad) > nx:  # a header line of nx words, not a line of the matrix
                continue
            rows += 1
            if bad and len(dropped) < 3:
                dropped.append(f"line {number} holds {bad[0]!r}")
    if rows > ny:
        raise InputError(
            f"{str(path)!r}: the text reader kept {ny} of the {rows} lines of {nx} values "
            f"({'; '.join(dropped) or 'lines it could not read'}): a dropped line would move "
            f"every later one. Mark missing points as nan (and choose a fill), or save the "
            f"scan as .npy")


#: The file endings of plain-text matrices and coordinate lists (read by SurfaceTopography's
#: text readers, which have no ending of their own).
TEXT_SUFFIXES = (".txt", ".asc", ".dat", ".xyz", ".csv")
#: Channel names that mark the heights in a file of several unnamed arrays (NPZ, HDF5, MAT).
HEIGHT_CHANNEL_NAMES = ("height", "heights", "topography", "z")
#: Relative tolerance of ``missing_value``: a float32 file holds a placeholder to about
#: 6e-8 of it, and no measured height lies within 1e-6 of an instrument's placeholder.
MISSING_VALUE_RTOL = 1e-6
#: Readers of files that hold several arrays with nothing to say which are heights.
_ARRAY_CONTAINER_READERS = ("NPZReader", "H5Reader", "MatReader")


def _printable(text: str, limit: int = 300) -> str:
    """``text`` on one line without control characters (a reader's message may quote the
    file's raw bytes), shortened to ``limit`` characters."""
    text = " ".join("".join(c if c.isprintable() else " " for c in text).split())
    return text if len(text) <= limit else text[:limit - 3] + "..."


def _reader_messages(exc: Exception) -> dict[str, str]:
    """SurfaceTopography's "tried XReader: message" blocks of a failed format detection."""
    found = re.findall(r"tried (\w+):\s*(.*?)(?=\n\s*tried \w+:|\Z)", str(exc), re.S)
    return {name: msg for name, msg in found}


def _open_error(path: Path, exc: Exception) -> InputError:
    """A short error for a file SurfaceTopography cannot read: what the reader of its file
    ending said (not the 17 readers' messages with the file's raw bytes)."""
    suffix = path.suffix.lower()
    tried = _reader_messages(exc)
    own = [r.__name__ for r in _readers_of(path)]
    if suffix in TEXT_SUFFIXES:
        own = ["XYZReader", "AscReader"]
    said = [f"{name}: {_printable(tried[name])}" for name in own if name in tried]
    hint = ""
    if suffix in TEXT_SUFFIXES:
        hint = ("; a text scan is a matrix of whitespace-separated numbers with a decimal "
                "point (no commas or semicolons between values), or a list of x y z lines")
    if said:
        return InputError(f"{str(path)!r} cannot be read: " + "; ".join(said) + hint)
    if not tried:
        return InputError(f"{str(path)!r} is not a topography that SurfaceTopography can read "
                          f"({type(exc).__name__}: {_printable(str(exc))})")
    return InputError(f"{str(path)!r} is not a topography that SurfaceTopography can read "
                      f"(no reader takes files ending in {suffix or 'nothing'!r} and none of "
                      f"the {len(tried)} it tried read it{hint})")


def _open(path: Path):
    if path.stat().st_size == 0:
        raise InputError(f"{str(path)!r} is empty")
    if path.suffix.lower() == ".npy":
        _check_npy_complete(path)
    require_installed(SCAN_READER, "reading scans", SCAN_READER_EXTRA)
    try:
        from SurfaceTopography import open_topography
    except ImportError as exc:  # installed, but broken (a missing library of its own)
        raise InputError(f"reading scans needs {SCAN_READER}, which fails to import: "
                         f"{exc}") from None
    with _readers_contained():
        try:
            reader = open_topography(str(path))
        except Exception as exc:  # the readers raise many types for files they cannot read
            raise _open_error(path, exc) from None
        name = type(reader).__name__
        if name == "HGTReader" and path.suffix.lower() != ".hgt":
            # the NASA SRTM reader has no header to check: it takes any file of 2 n^2 bytes
            # (a 32-byte text file reads as a 4 x 4 map), so it is trusted only for .hgt files
            why = "only the header-less NASA SRTM reader took it; rename it to .hgt if it is one"
        elif not reader.channels:
            # the detection takes the first reader that opens the file without an exception:
            # the MATLAB reader opened 128 bytes of an FRT file, the Nanoscope reader a file
            # cut inside its text header, both without a channel (an IndexError followed)
            why = f"{name} found no data channel in it"
        else:
            return reader
        _close(reader)
        own, said = _own_reader(path)
    if own is not None:
        return own
    if said:
        raise InputError(f"{str(path)!r} cannot be read: {said}")
    raise InputError(f"{str(path)!r} is not a topography that SurfaceTopography can read ({why})")


def _readers_of(path: Path) -> list:
    """SurfaceTopography's reader classes whose format is ``path``'s file ending."""
    from SurfaceTopography.IO import readers

    return [r for r in readers if f".{r.format()}" == path.suffix.lower()]


def _own_reader(path: Path):
    """The reader of ``path``'s file ending opened on it where it finds a data channel there,
    else None and what it says about the file ("" where no reader has that ending)."""
    own = _readers_of(path)
    if not own:
        return None, ""
    try:
        reader = own[0](str(path))
    except Exception as exc:
        return None, f"{own[0].__name__}: {_printable(str(exc))}"
    if reader.channels:
        return reader, ""
    _close(reader)
    return None, (f"{own[0].__name__}: no data channel in its {path.stat().st_size} bytes; is "
                  "the file truncated?")


def _header_size_unit(ch, path: Path) -> str | None:
    """The unit of the size a text scan's header gives ("Width: 20 um"), where the reader
    kept the size but not its unit (the heights' unit is not given); None elsewhere."""
    meta = (getattr(ch, "info", None) or {}).get("raw_metadata") or {}
    units = {meta.get("xunit"), meta.get("yunit")} - {None}
    if not units:
        return None
    if len(units) > 1:
        raise InputError(f"{str(path)!r} gives its size in two units ({', '.join(units)}): "
                         "give size= in one (CLI --size) after removing the header's")
    return units.pop()


def _is_point_list(path: Path) -> bool:
    """Whether a text file of a few columns holds x y z (...) lines of a grid: its first two
    columns repeat few values whose pairs cover the lines (a matrix 4 values wide has
    heights there, all different)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rows = np.genfromtxt(path, comments="#", invalid_raise=False, ndmin=2)
    rows = rows[np.isfinite(rows[:, :2]).all(axis=1)] if rows.ndim == 2 and rows.shape[1] > 1 \
        else np.empty((0, 2))
    if len(rows) < 2:
        return False
    u0, u1 = (len(np.unique(rows[:, k])) for k in (0, 1))
    return u0 < len(rows) and u1 < len(rows) and u0 * u1 >= len(rows)


def _refuse_own_file(path: Path) -> None:
    """Refuse a netCDF file that roughflow wrote (global attribute ``roughflow_version``):
    a surface file is read by the commands as it is, and any other is a result, not a
    scan (read as plain HDF5, both gave a misleading "does not give its length unit")."""
    if path.suffix.lower() != ".nc":
        return
    import netCDF4

    try:
        with netCDF4.Dataset(str(path)) as nc:
            attrs = set(nc.ncattrs())
            if "roughflow_version" not in attrs:
                return
            made = str(nc.getncattr("command")) if "command" in attrs else None
            names = set(nc.variables)
    except OSError:
        return
    by = f" (written by {made!r})" if made else ""
    if "heights" in names and names <= {"heights", "x", "y"}:
        raise InputError(f"{str(path)!r} is already a roughflow surface file{by}: pass it "
                         "to roughflow contact, leak or threshold as it is (import reads "
                         "instrument files and height arrays)")
    raise InputError(f"{str(path)!r} is a roughflow result{by}, not a scan: import reads "
                     "instrument files and height arrays")


def _netcdf_y_first(path: Path) -> bool:
    """Whether ``path`` is a netCDF file whose ``heights`` are stored over (y, x): the
    order of xarray and CF-style files, which SurfaceTopography reads as (x, y) (measured:
    a square scan transposed without a word, sigma_x and sigma_y swapped)."""
    if path.suffix.lower() != ".nc":
        return False
    import netCDF4

    try:
        with netCDF4.Dataset(str(path)) as nc:
            var = nc.variables.get("heights")
            return var is not None and tuple(var.dimensions) == ("y", "x")
    except OSError:
        return False


#: The start of a reader library's message that is cleaned for the debug log (igor2 quotes
#: whole files; :func:`_printable` keeps 300 characters of it).
_READER_MESSAGE_CHARS = 1000


class _ReaderRecords(logging.Filter):
    """Holds back the log records of other libraries than roughflow from the handlers it is
    added to, and passes each to roughflow's log at DEBUG, on one printable line."""

    def __init__(self) -> None:
        super().__init__()
        self._last: logging.LogRecord | None = None

    def filter(self, record: logging.LogRecord) -> bool:
        if record.name == "roughflow" or record.name.startswith("roughflow."):
            return True
        if record is not self._last and log.isEnabledFor(logging.DEBUG):
            self._last = record  # added to several handlers, it sees a record on each
            try:
                message = record.getMessage()
            except Exception:  # a library's malformed record must not fail its reader here
                message = str(record.msg)
            log.debug("%s logged: %s", record.name,
                      _printable(message[:_READER_MESSAGE_CHARS]))
        return False


@contextlib.contextmanager
def _readers_contained():
    """Keep what SurfaceTopography's readers and their libraries log or warn from the user's
    standard error; -vv (DEBUG) shows each, shortened. Trying a truncated 4 MB .opd file as an
    Igor wave, igor2 logged 6.5 MB of its raw bytes, even under ``roughflow -q``. A library's
    records end at the root logger's handlers, or logging's last resort where it has none:
    a filter there holds them back. Records of roughflow's own loggers pass, and the readers'
    exceptions propagate."""
    records = _ReaderRecords()
    handlers = [h for h in (*logging.getLogger().handlers, logging.lastResort) if h is not None]
    for h in handlers:
        h.addFilter(records)
    caught: list[warnings.WarningMessage] = []
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            yield
    finally:
        for h in handlers:
            h.removeFilter(records)
        for message in dict.fromkeys(f"{w.category.__name__}: {w.message}" for w in caught):
            log.debug("a reader warned: %s", _printable(message[:_READER_MESSAGE_CHARS]))


def _close(reader) -> None:
    """Close ``reader``'s file once the heights are copied. The netCDF reader maps its file
    and warns on stderr when it is closed (or collected) while the reader's own masked
    arrays still refer to the map ("Cannot close a netcdf_file opened with mmap=True"),
    which they do after every read of a masked scan: closed here, without that warning
    (the map stays valid while anything refers to it)."""
    close = getattr(reader, "close", None)
    if close is None:
        return
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="Cannot close a netcdf_file",
                                category=RuntimeWarning)
        close()


def _channel_list(reader) -> str:
    return ", ".join(f"{c.index}: {c.name}" for c in reader.channels)


def _channel(reader, channel, path: Path):
    channels = reader.channels
    if channel is None:
        if type(reader).__name__ not in _ARRAY_CONTAINER_READERS or len(channels) == 1:
            return reader.default_channel
        # a container of arrays (an .npz, HDF5 or MATLAB file) says nothing about which
        # array is the heights; its reader takes the first (measured: "phase" before
        # "height", MATLAB's X of X, Y, Z)
        named = [c for c in channels if str(c.name).lower() in HEIGHT_CHANNEL_NAMES]
        if len(named) == 1:
            log.info("%s: read the array %r of %s (its name marks heights)", path,
                     named[0].name, _channel_list(reader))
            return named[0]
        raise InputError(f"{str(path)!r} holds several arrays ({_channel_list(reader)}) and "
                         "none named as heights (height, heights, topography or z): choose "
                         "one with channel= (CLI --channel)")
    # a name first, then an index; a Python int is an index only (a way that stays
    # unambiguous where a channel is named "1")
    by_index = isinstance(channel, (int, np.integer))
    named = [] if by_index else [c for c in channels if str(c.name) == str(channel)]
    if len(named) > 1:
        # an AFM file may hold trace and retrace "Height": the first was taken without a word
        first = named[0].index
        raise InputError(f"channel {channel!r} names {len(named)} channels of {str(path)!r} "
                         f"({', '.join(f'{c.index}: {c.name}' for c in named)}): choose one by "
                         f"its index, e.g. channel={first} (CLI --channel {first})")
    found = named or [c for c in channels if str(c.index) == str(channel)]
    if found:
        return found[0]
    raise InputError(f"channel {channel!r} not in the scan (channels: "
                     f"{_channel_list(reader)})")


def _twins(reader, ch) -> list:
    """The other channels of ``reader`` with ``ch``'s name (trace and retrace "Height")."""
    return [c for c in reader.channels if c.name == ch.name and c.index != ch.index]


def _channel_label(reader, ch) -> str:
    """The channel's name, with its index where another channel has the same name (the
    record must say which was read: an AFM file may hold trace and retrace "Height")."""
    return f"{ch.name} (channel {ch.index})" if _twins(reader, ch) else str(ch.name)


def _default_twin_message(reader, ch) -> str:
    """The warning where the file's default channel shares its name with others: the
    reader takes the first without a word, as a name that two channels share did before it
    was refused. Warned, not refused: the file's default is a defined choice, and the
    imports of such files without a channel (docs/measured.md's AFM example, its
    benchmark) stay as they were."""
    same = [ch, *_twins(reader, ch)]
    listed = ", ".join(f"{c.index}: {c.name}" for c in sorted(same, key=lambda c: c.index))
    picks = " / ".join(f"--channel {c.index}" for c in sorted(same, key=lambda c: c.index))
    return (f"{len(same)} channels are named {ch.name!r} ({listed}; an AFM's trace and "
            f"retrace?): read channel {ch.index}, the file's default; choose one by its "
            f"index with channel= (CLI {picks})")


def _check_text_scan(path: Path, ch) -> None:
    """Refuse a plain-text scan read wrongly as a matrix: a list of points whose columns
    were taken for the scan's lines, or a matrix with dropped lines."""
    nx, ny = ch.nb_grid_pts
    if nx <= 4 < ny and ny > 4 * nx and _is_point_list(path):
        # the coordinate-list reader refused it (a point missing from the grid, a
        # fourth column) and the matrix reader took its columns for the scan's lines
        raise InputError(f"{str(path)!r} looks like a list of points ({ny} lines of "
                         f"{nx} values), not a matrix: SurfaceTopography reads a list "
                         "of x y z lines (three columns) only where it covers every "
                         "point of a uniform grid; drop other columns and write missing "
                         "points with a height of nan")
    _check_text_complete(path, tuple(ch.nb_grid_pts))


def _file_unit_and_size(reader, ch, path: Path) -> tuple[str | None, tuple[float, ...] | None]:
    """The length unit and physical size the channel's file gives (each None where it gives
    none); a channel whose data are not heights (its data unit is not its lateral one) is
    refused."""
    file_unit, file_size = ch.unit, ch.physical_sizes
    if isinstance(file_unit, tuple):  # (lateral, data) units: the data are not heights
        lateral_unit, data_unit = (file_unit + (None, None))[:2]
        if data_unit is None or data_unit != lateral_unit:
            raise InputError(f"{str(path)!r} channel {ch.name!r} is not a height map (its "
                             f"data unit is {data_unit!r}, its lateral unit "
                             f"{lateral_unit!r}); pick a height channel (channels: "
                             f"{_channel_list(reader)})")
        file_unit = lateral_unit
    if file_size is not None:  # plain floats in messages, not numpy's repr
        file_size = tuple(float(v) for v in file_size)
    return file_unit, file_size


def read_scan(path: str | os.PathLike, *,
              size: str | float | Sequence[str | float] | None = None, unit: str | None = None,
              height_unit: str | None = None, detrend_mode: str = SCAN_DETREND,
              fill: str = SCAN_FILL, crop: str | None = None,
              channel: str | int | None = None,
              periodic: bool = False, missing_value: float | None = None) -> Surface:
    """Read a measured topography into a dimensionless :class:`Surface` with
    :class:`~roughflow.surface.ScanInfo`.

    size: physical size where the file gives none: one length (square) or two, as
        quantities ("500nm", ("0.126mm", "0.094mm")) or numbers in ``unit``.
    unit: length unit of the file's lateral sizes and heights where it gives none.
    height_unit: unit of the heights where the file gives none and it differs from
        ``unit``.
    detrend_mode: ``"none"``, ``"plane"``, ``"curvature"``, ``"lines-x"`` or ``"lines-y"``
        (:func:`detrend`; the last two level the scan lines, :func:`level_lines`).
    fill: ``"none"`` (a scan with missing points is refused), ``"harmonic"`` or ``"min"``
        (:func:`fill_missing`); the number filled is recorded.
    crop: grid window "i0:i1,j0:j1" kept (e.g. to cut a border of missing points), or
        ``"defined"``: the largest window without missing points
        (:func:`largest_defined_window`).
    channel: name or index of the data channel (default: the file's height channel); a
        string is matched to the names first, an int to the indices only. A name that two
        channels share (trace and retrace "Height") is refused, listing their indices; the
        default, where another channel shares its name, is read with a warning naming them.
    periodic: the scan is periodic (e.g. a simulated one): no boundary treatment later.
    missing_value: the number that marks missing points in the file (an instrument's
        placeholder such as -999999 or 1e38), in the file's own numbers; matched to a
        relative 1e-6 (a float32 file holds 1e38 as 9.99999968e37). NaN always counts.

    Every check happens before the heights are processed; bad input raises
    :class:`InputError` naming the value.
    """
    path = Path(path)
    require_readable(path, f"scan file {str(path)!r}")
    _refuse_own_file(path)
    if detrend_mode not in DETREND_MODES:
        raise InputError(f"detrend must be one of {DETREND_MODES}, got {detrend_mode!r}")
    if fill not in FILL_METHODS:
        raise InputError(f"fill must be one of {FILL_METHODS}, got {fill!r}")
    if missing_value is not None:
        try:
            missing_value = float(missing_value)
        except (TypeError, ValueError):
            raise InputError(f"missing_value must be a number, got {missing_value!r}") from None
        if not math.isfinite(missing_value):
            raise InputError(f"missing_value must be finite (nan always counts as missing), "
                             f"got {missing_value!r}")
    notes: list[str] = []  # logged, and kept with the surface (ScanInfo.warnings)

    def warn(message: str) -> None:
        log.warning("%s: %s", path, message)
        notes.append(message)

    reader = _open(path)
    try:  # closed on every error path too (an open file per failed import otherwise)
        ch = _channel(reader, channel, path)
        if channel is None and _twins(reader, ch):
            warn(_default_twin_message(reader, ch))
        if ch.dim != 2 or not ch.is_uniform:
            raise InputError(f"{str(path)!r} channel {ch.name!r} is a {ch.dim}D "
                             f"{'uniform' if ch.is_uniform else 'non-uniform'} topography; "
                             "roughflow needs a 2D map on a uniform grid")
        reader_name = type(reader).__name__
        if reader_name == "AscReader":
            _check_text_scan(path, ch)
        file_unit, file_size = _file_unit_and_size(reader, ch, path)
        if file_unit is not None and (unit is not None or height_unit is not None):
            given = [f"{k}={v!r} (CLI --{k.replace('_', '-')})"
                     for k, v in (("unit", unit), ("height_unit", height_unit)) if v is not None]
            raise InputError(f"{str(path)!r} already gives its unit ({file_unit}): drop "
                             f"{' and '.join(given)}")
        if file_size is not None and size is not None:
            given_in = file_unit or _header_size_unit(ch, path)
            raise InputError(f"{str(path)!r} already gives its size {file_size[0]:g} x "
                             f"{file_size[1]:g}{' ' + given_in if given_in else ''}: drop "
                             f"size={size!r} (CLI --size)")
        header_unit = _header_size_unit(ch, path) if file_unit is None and file_size else None
        if header_unit is not None:
            # a text header that gives the size with its unit ("Width: 20 um") but not the
            # heights' unit: SurfaceTopography keeps the numbers and drops the unit, so the
            # size was read in unit= (measured: 20 um read as 20 nm with --unit nm)
            if unit is not None and length_factor(unit, "unit") != length_factor(header_unit,
                                                                                  "unit"):
                raise InputError(f"{str(path)!r} gives its size in {header_unit} "
                                 f"({file_size[0]:g} x {file_size[1]:g}); unit={unit!r} would "
                                 f"read it in {unit}: give the heights' unit with height_unit= "
                                 "(CLI --height-unit) and drop unit=")
            if unit is None and height_unit is None:
                raise InputError(f"{str(path)!r} gives its size in {header_unit} but not the unit "
                                 "of its heights: pass height_unit= (CLI --height-unit), or unit= "
                                 f"where they are in {header_unit} too")
            height_unit, unit, file_unit = height_unit or unit, None, header_unit
        # a size with its units and height_unit say all that unit= would (the size must then
        # carry units: _sizes refuses bare numbers without unit=)
        st_unit = unit
        if file_unit is None and unit is None and height_unit is not None and size is not None:
            st_unit = height_unit
        missing = []  # named together, not one per run
        if file_unit is None and st_unit is None:
            missing.append(_missing_unit(size))
        if file_size is None and size is None:
            missing.append("its physical size: pass size= (e.g. '500nm' or '0.126mm,0.094mm'; "
                           "CLI --size)")
        if missing:
            hint = ""
            if reader_name == "H5Reader" and path.suffix.lower() == ".nc":
                hint = (" (a netCDF-4 file, read as plain HDF5 without its attributes: "
                        "SurfaceTopography reads the length and unit attributes of netCDF-3 "
                        "files, e.g. xarray's to_netcdf(path, format='NETCDF3_64BIT'))")
            raise InputError(f"{str(path)!r} does not give " + ", nor ".join(missing) + hint)
        lateral = length_factor(file_unit or st_unit, "unit")
        if file_size is not None:
            lx_m, ly_m = (float(v) * lateral for v in file_size)
            if not (math.isfinite(lx_m) and math.isfinite(ly_m) and lx_m > 0 and ly_m > 0):
                raise InputError(f"{str(path)!r} gives the size {tuple(file_size)}: not positive")
        else:
            # bare numbers are in unit=, else in the file's own unit
            lx_m, ly_m = scan_size(size, unit if unit is not None else file_unit)
        vertical = lateral if height_unit is None else length_factor(height_unit, "height_unit")
        auto_crop = crop is not None and str(crop).strip() == SCAN_CROP_DEFINED
        y_first = _netcdf_y_first(path)
        # the netCDF reader takes the grid from the x and y dimensions, the HDF5 one (netCDF-4
        # files) from the array as stored
        grid = tuple(ch.nb_grid_pts)[::-1] if y_first and reader_name != "NCReader" else \
            tuple(ch.nb_grid_pts)
        window = parse_crop(crop, grid)

        kw = {} if file_size is not None else {"physical_sizes": tuple(float(v) / lateral for v in
                                                                       (lx_m, ly_m))}
        if ch.unit is None:
            kw["unit"] = file_unit or st_unit
        try:
            with _readers_contained():
                topo = ch.topography(**kw)
                raw = topo.heights()
        except Exception as exc:
            raise InputError(f"cannot read the heights of {str(path)!r} "
                             f"({type(exc).__name__}: {exc})") from None
        if y_first:
            log.info("%s: heights stored over (y, x), transposed to roughflow's (x, y)", path)
            raw = raw.T
        if raw.shape != grid:
            raise InputError(f"{str(path)!r}: the reader gave {raw.shape[0]} x {raw.shape[1]} "
                             f"heights for a {grid[0]} x {grid[1]} grid")
        missing = np.ma.getmaskarray(raw) | ~np.isfinite(np.ma.getdata(raw))
        if missing_value is not None:
            missing |= np.isclose(np.ma.getdata(raw), missing_value, rtol=MISSING_VALUE_RTOL,
                                  atol=0.0)
        h = np.array(np.ma.getdata(raw), dtype=np.float64) * vertical
        del raw, topo
    finally:
        _close(reader)
    nx0, ny0 = h.shape
    if auto_crop:
        window = largest_defined_window(missing)
        _check_window(window, h.shape, f"crop={SCAN_CROP_DEFINED!r} (the largest window "
                      "without missing points)")
    if window is not None:
        h, missing = h[window], missing[window]
        lx_m *= h.shape[0] / nx0
        ly_m *= h.shape[1] / ny0
    # the same size in other units, or cropped from a larger one, to the same float
    from roughflow.units import canonical

    lx_m, ly_m = canonical(lx_m), canonical(ly_m)
    if min(h.shape) < 4:
        raise InputError(f"{str(path)!r} has {h.shape[0]} x {h.shape[1]} points; at least "
                         "4 x 4 are needed (line scans are not read)")
    dx, dy = lx_m / h.shape[0], ly_m / h.shape[1]
    if file_size is not None and reader_name != "AscReader":
        if abs(dx / dy - 1) > SCAN_PIXEL_ASPECT_WARN:  # stated by the file itself
            log.info("%s: pixels of %.4g m along x and %.4g m along y, as the file states",
                     path, dx, dy)
    elif abs(dx / dy - 1) > SCAN_PIXEL_ASPECT_WARN:
        if size is not None and len(_size_parts(size)) == 1:
            # one size is both sides (scan_size): a grid that is not square then has
            # rectangular pixels, and nothing was swapped
            warn(f"one size ({size!r}) was given for the {nx0} x {ny0} grid and taken for "
                 f"both sides, so the pixels are {dx:.4g} m along x and {dy:.4g} m along y. "
                 "If the instrument's pixels are square, give both sides, lx,ly (size=, CLI "
                 f"--size), with lx:ly = {nx0}:{ny0}")
        else:
            warn(f"the pixels are {dx:.4g} m along x and {dy:.4g} m along y ({h.shape[0]} x "
                 f"{h.shape[1]} points, {lx_m:.4g} m x {ly_m:.4g} m). If the instrument's "
                 "pixels are square, the axes are swapped: roughflow's first index is x; a "
                 "plain-text matrix is read with each row a line along x (its first index is "
                 "y), a .npy array as it is (np.savetxt(f, h.T) writes an [x, y] array h for "
                 "the text reader)")
    n_missing = int(missing.sum())
    if n_missing == missing.size:
        raise InputError(f"{str(path)!r} has no defined point in the window kept")
    if n_missing and fill == "none":
        raise InputError(f"{str(path)!r} has {n_missing} missing "
                         f"point{'' if n_missing == 1 else 's'} "
                         f"({100 * n_missing / missing.size:.2g} % of {h.shape[0]} x "
                         f"{h.shape[1]}): choose a fill ({', '.join(FILL_METHODS[1:])}) "
                         f"or crop {'it' if n_missing == 1 else 'them'} away; "
                         + _defined_window_hint(missing, window, (nx0, ny0)))
    if n_missing > SCAN_FILL_WARN_FRACTION * missing.size:
        warn(f"{100 * n_missing / missing.size:.3g} % of the points are missing and filled "
             f"({fill}): a filled region is smooth (harmonic) or a flat basin (min), and where "
             "it is large it, not the measured surface, shapes the contact; "
             + _defined_window_hint(missing, window, (nx0, ny0)))
    h[missing] = 0.0
    level = float(np.max(np.abs(h)))  # the heights' magnitude before detrending
    h = detrend(h, lx_m, ly_m, detrend_mode, defined=~missing)
    if n_missing:
        h = fill_missing(h, missing, fill)
    with np.errstate(over="ignore"):
        overflow = not np.isfinite(h).all() or not np.isfinite(np.std(h))
    if overflow:
        raise InputError(f"{str(path)!r}: heights up to {level:.4g} m overflow the "
                         "statistics: a placeholder that marks missing points (such as 1e38 "
                         "or -999999)? Name it with missing_value= (CLI --missing-value) and "
                         "choose a fill")
    if np.ptp(h) <= SCAN_FLAT_RELATIVE * level:
        # round-off of the detrending leaves ~1e-16 of the heights (a constant map of 3.0
        # came out 1.5e-24 m rough and ran through a whole leak study)
        raise InputError(f"{str(path)!r} is flat after detrending ({detrend_mode}): its "
                         f"heights vary by {float(np.ptp(h)):.3g} m against levels up to "
                         f"{level:.3g} m, no roughness to analyse")
    length = math.sqrt(lx_m * ly_m)
    lx, ly = lx_m / length, ly_m / length
    h /= length
    info = ScanInfo(
        source=str(path), reader=str(reader.name()), channel=_channel_label(reader, ch),
        length_scale=length, rms_gradient=rms_gradient(h, lx, ly, periodic=periodic),
        detrend=detrend_mode, fill=fill, filled=n_missing,
        crop="none" if window is None else _window_text(window, (nx0, ny0)),
        periodic=bool(periodic),
        missing_value="none" if missing_value is None else repr(missing_value))
    lo, hi = SCAN_GRADIENT_WARN
    if not lo <= info.rms_gradient <= hi:
        warn(f"the rms gradient is {info.rms_gradient:.3g} (rms height "
             f"{float(np.std(h)) * length:.4g} m over {lx_m:.4g} m x {ly_m:.4g} m): measured "
             "surfaces have about 1e-3 to 2. Check the units: the heights were read in "
             f"{height_unit or file_unit or st_unit} and the lateral sizes "
             f"{_lateral_units(size, file_unit or st_unit)} (heights in nm read as um are "
             "1000 times too steep), "
             "and look for a placeholder value that marks missing points (such as -999999): "
             "name it with missing_value= (CLI --missing-value)")
    if notes:
        info = dataclasses.replace(info, warnings="; ".join(notes))
    surface = Surface.from_array(h, lx=lx, ly=ly)
    return Surface(heights=surface.heights, lx=surface.lx, ly=surface.ly, scan=info)
