"""Exceptions shared by all stages."""

from __future__ import annotations

import math

import numpy as np


class InputError(ValueError):
    """Bad input (config, CLI or API argument), raised before any work starts."""


class ConvergenceError(RuntimeError):
    """A solver did not reach its tolerance; carries the residual it reached."""

    def __init__(self, message: str, *, residual: float, iterations: int):
        super().__init__(f"{message} (residual {residual:.3e} after {iterations} iterations)")
        self.residual = residual
        self.iterations = iterations


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


def require_field(name: str, array, *, ndim: int = 2) -> np.ndarray:
    """Return ``array`` as float64, or raise if it has the wrong rank or non-finite values."""
    a = np.asarray(array, dtype=np.float64)
    if a.ndim != ndim:
        raise InputError(f"{name} must be a {ndim}D array, got shape {a.shape}")
    if a.size == 0:
        raise InputError(f"{name} is empty (shape {a.shape})")
    bad = ~np.isfinite(a)
    if bad.any():
        idx = tuple(int(i) for i in np.argwhere(bad)[0])
        raise InputError(f"{name} has {int(bad.sum())} non-finite values, first at {idx}: {a[idx]}")
    return a
