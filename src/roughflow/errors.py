"""Exceptions shared by all stages."""

from __future__ import annotations

import math
from numbers import Integral
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from collections.abc import Iterable

    import numpy as np
    from numpy.typing import ArrayLike

__all__ = ["InputError", "ResourceError", "OutputError", "ConvergenceError", "require_finite",
           "require_positive", "require_cell", "require_installed", "MAX_SEED", "require_int",
           "require_seeds", "require_distinct", "check_axis", "check_nu", "plain_array",
           "require_mask", "require_finite_values", "require_numbers", "require_squares_in_range",
           "require_field"]


class InputError(ValueError):
    """Bad input (config, CLI or API argument), raised before any work starts."""


class ResourceError(InputError):
    """The work would need more memory than the machine (or the job's limit) has; raised
    before anything is allocated (:mod:`roughflow.resources`)."""


class OutputError(OSError):
    """An output could not be written after the work was done (the disk or quota full, the
    folder made unwritable meanwhile); raised naming the file, with nothing of it left."""


class ConvergenceError(RuntimeError):
    """A solver did not reach its tolerance; carries the residual it reached, and ``inputs``:
    the arrays and values that reproduce the failed solve, where a caller that knows them
    adds them (the ladder scene: ``flow.solve(gap, axis, lx=, ly=)``), else None."""

    def __init__(self, message: str, *, residual: float, iterations: int):
        super().__init__(f"{message} (residual {residual:.3e} after {iterations} iterations)")
        self.residual = residual
        self.iterations = iterations
        self.inputs: dict | None = None


def require_finite(name: str, value: float) -> float:
    """Return ``float(value)``, or raise :class:`InputError` naming it if it is not finite."""
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(x):
        raise InputError(f"{name} must be finite, got {value!r}")
    return x


def require_positive(name: str, value: float) -> float:
    """Return ``float(value)``, or raise :class:`InputError` if it is not finite and > 0."""
    x = require_finite(name, value)
    if x <= 0:
        raise InputError(f"{name} must be positive, got {value!r}")
    return x


def require_cell(lx: float, ly: float | None, shape: tuple[int, ...]) -> tuple[float, float]:
    """The cell lengths (lx, ly) of a field of ``shape`` points; ``ly`` None is lx on a
    square grid and an :class:`InputError` on any other. A non-square grid is a square
    cell of rectangular pixels (``surface.generate`` at gamma != 1) or a rectangle of square
    pixels (``Surface.from_array``, scans): guessing either gave the other's users sigma off
    by 30 % and gamma 1.67 for an isotropic surface."""
    x = require_positive("lx", lx)
    if ly is not None:
        return x, require_positive("ly", ly)
    nx, ny = shape[0], shape[1]
    if nx != ny:
        raise InputError(f"the grid is {nx} x {ny}: give ly too (the Surface's ly; "
                         f"{x * ny / nx:.6g} for square pixels, {x:g} for a square cell)")
    return x, x


def require_installed(module: str, purpose: str, extra: str) -> None:
    """:class:`InputError` unless ``module`` (an optional dependency) is installed; found,
    not imported, so that a plan can check it without the import's cost."""
    import importlib.util

    if importlib.util.find_spec(module) is None:
        raise InputError(f"{purpose} needs {module}, which is not installed: pip install "
                         f"'roughflow[{extra}]'")


#: Largest seed: seeds are stored as 64-bit integers in the netCDF files.
MAX_SEED = 2**63 - 1


def require_int(name: str, value: int | np.integer, *, minimum: int | None = None,
                maximum: int | None = None) -> int:
    """Return ``value`` as an int, or raise :class:`InputError` naming it if it is not an
    integer (bools and floats are refused) or lies outside [``minimum``, ``maximum``]."""
    if isinstance(value, bool) or not isinstance(value, Integral):
        raise InputError(f"{name} must be an integer, got {value!r}")
    v = int(value)
    if minimum is not None and v < minimum:
        raise InputError(f"{name} must be >= {minimum}, got {value!r}")
    if maximum is not None and v > maximum:
        raise InputError(f"{name} must be <= {maximum}, got {value!r}")
    return v


def require_seeds(name: str, seeds: Iterable[int | np.integer]) -> tuple[int, ...]:
    """A non-empty tuple of distinct seeds in [0, :data:`MAX_SEED`] (a duplicate seed would
    give a duplicate coordinate in the datasets)."""
    return require_distinct(name, tuple(
        require_int(f"{name} entry", s, minimum=0, maximum=MAX_SEED) for s in seeds))


def require_distinct(name: str, values: tuple) -> tuple:
    """``values``, refused when empty or with a repeated entry (naming the repeats)."""
    if not values:
        raise InputError(f"{name} is empty")
    dup = sorted({v for v in values if values.count(v) > 1})
    if dup:
        raise InputError(f"{name} must be distinct, got {list(values)} ({dup} repeated)")
    return values


def check_axis(axis: int | str) -> int:
    """Return ``axis`` as 0 (x) or 1 (y); ``"x"`` and ``"y"`` name them too. Anything else,
    including ``True`` and ``1.0`` (which compare equal to 1), raises :class:`InputError`."""
    from roughflow.defaults import AXIS_NAMES

    if isinstance(axis, str) and axis in AXIS_NAMES:
        return AXIS_NAMES.index(axis)
    if isinstance(axis, Integral) and not isinstance(axis, bool) and axis in (0, 1):
        return int(axis)
    raise InputError(f"axis must be 0 or 'x', 1 or 'y', got {axis!r}")


def check_nu(nu: float) -> float:
    """A fixed finite-size-scaling exponent nu inside ``defaults.NU_BOUNDS`` (the range a
    free nu is searched in), or :class:`InputError`."""
    from roughflow.defaults import NU_BOUNDS

    v = require_finite("nu", nu)
    if not NU_BOUNDS[0] <= v <= NU_BOUNDS[1]:
        raise InputError(f"nu must lie in [{NU_BOUNDS[0]:g}, {NU_BOUNDS[1]:g}], got {nu!r}")
    return v


def plain_array(name: str, array: ArrayLike) -> np.ndarray:
    """``array`` as a numpy array, refusing what ``np.asarray`` would misread: masked
    values (netCDF4 returns masked arrays for variables with a fill value; asarray keeps
    the fill behind the mask as if it were data) and an xarray DataArray whose dims put y
    first (roughflow arrays are [x, y])."""
    import numpy as np

    if isinstance(array, np.ma.MaskedArray):
        masked = np.ma.getmaskarray(array)
        if masked.any():
            idx = tuple(int(i) for i in np.argwhere(masked)[0])
            raise InputError(f"{name} has {int(masked.sum())} masked values, first at {idx}: "
                             "fill or crop them first (roughflow reads the data behind a "
                             "mask as numbers)")
        array = array.data
    dims = getattr(array, "dims", None)
    if dims is not None and tuple(dims) == ("y", "x"):
        raise InputError(f"{name} has dims ('y', 'x'); roughflow arrays are [x, y]: pass "
                         ".transpose('x', 'y')")
    return np.asarray(array)


def require_mask(name: str, mask: ArrayLike) -> np.ndarray:
    """Return ``mask`` as a 2D numpy bool array, or raise :class:`InputError` naming it (a
    0/255 or 0/1 integer mask is refused, not cast: its mean is not a fraction)."""
    m = plain_array(name, mask)
    if m.dtype.kind != "b":
        raise InputError(f"{name} must be a boolean array, got dtype {m.dtype}")
    if m.ndim != 2:
        raise InputError(f"{name} must be a 2D array, got shape {m.shape}")
    if m.size == 0:
        raise InputError(f"{name} is empty (shape {m.shape})")
    return m


def require_finite_values(name: str, a: np.ndarray) -> np.ndarray:
    """``a`` unchanged (no cast), or :class:`InputError` naming its first nan or inf."""
    import numpy as np

    # one summing pass, without the boolean array: any nan or inf makes the sum non-finite
    # (an overflow of finite values does too, and the exact scan below then finds nothing)
    with np.errstate(over="ignore", invalid="ignore"):
        total = float(a.sum())
    if math.isfinite(total):
        return a
    bad = ~np.isfinite(a)
    if bad.any():
        idx = tuple(int(i) for i in np.argwhere(bad)[0])
        raise InputError(f"{name} has {int(bad.sum())} non-finite values, first at {idx}: {a[idx]}")
    return a


def require_numbers(name: str, raw: np.ndarray, hint: str = "") -> np.ndarray:
    """``raw`` unchanged; :class:`InputError` where it is a boolean array: a mask passed
    where numbers belong (a contact mask as the gap flowed as a gap of 1 everywhere)."""
    if raw.dtype.kind == "b":
        raise InputError(f"{name} must hold numbers, got a boolean array (a mask?){hint}")
    return raw


def require_squares_in_range(name: str, value: float, heights: np.ndarray) -> float:
    """``value``, a sum of squares of the heights ``heights`` (numpy or CuPy) or a quantity
    made from one (their rms, their rms gradient), unchanged; :class:`InputError` naming
    the largest |h| where it overflowed (not finite) or underflowed (0 for heights that are
    not all equal). The one check of every such quantity: finite heights of 1e200 (in
    units of L) made them inf or nan, and heights of 1e-170 made them 0."""
    if math.isfinite(value) and (value != 0 or not heights.max() > heights.min()):
        return value  # 0 for equal heights is the true value
    flow = "overflow" if not math.isfinite(value) else "underflow"
    raise InputError(f"{name} out of range: their squares {flow} (largest |h| "
                     f"{float(abs(heights).max()):.3g}; heights in units of L)")


def require_field(name: str, array: ArrayLike, *, ndim: int = 2) -> np.ndarray:
    """Return ``array`` as a float64 numpy array, or raise if it has the wrong rank or
    non-finite values (or masked values, or xarray dims in the order (y, x), or booleans)."""
    import numpy as np

    raw = require_numbers(name, plain_array(name, array))
    if raw.dtype.kind == "c":  # a cast to float64 would drop the imaginary part silently
        raise InputError(f"{name} must be real, got complex values")
    try:
        a = raw.astype(np.float64, copy=False)
    except (TypeError, ValueError):
        raise InputError(f"{name} must hold numbers, got {raw.dtype} values") from None
    if a.ndim != ndim:
        raise InputError(f"{name} must be a {ndim}D array, got shape {a.shape}")
    if a.size == 0:
        raise InputError(f"{name} is empty (shape {a.shape})")
    return require_finite_values(name, a)
