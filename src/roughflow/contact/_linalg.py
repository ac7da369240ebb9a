"""Small dense helpers that avoid BLAS (multithreaded BLAS on 1D dot products oversubscribes
shared cores and was measured 20x slower than einsum here)."""

from __future__ import annotations

import numpy as np


def dot(a: np.ndarray, b: np.ndarray) -> float:
    """Sum of a * b over all elements, without BLAS."""
    return float(np.einsum("i,i->", a.ravel(), b.ravel()))
