"""Small dense helpers that avoid BLAS (multithreaded BLAS on 1D dot products oversubscribes
shared cores and was measured 20x slower than einsum here)."""

from __future__ import annotations

import math

import numpy as np

from roughflow.errors import require_squares_in_range


def dot(a: np.ndarray, b: np.ndarray) -> float:
    """Sum of a * b over all elements, without BLAS."""
    return float(np.einsum("i,i->", a.ravel(), b.ravel()))


def height_scale(h, xp=np) -> float:
    """rms of the centred heights ``h`` (flat; ``xp``: its array module), the unit of every
    contact residual; 1 for a flat surface. Heights whose squares overflow or underflow
    raise :class:`InputError` (:func:`roughflow.errors.require_squares_in_range`): the
    residual would be infinite, or absolute and below any tolerance at the start (heights x
    1e-200 would stop a solve at once with a_c = 1)."""
    mean_square = (dot(h, h) if xp is np else float(xp.dot(h, h))) / h.size
    if require_squares_in_range("surface heights", mean_square, h) > 0:
        return math.sqrt(mean_square)
    return 1.0
