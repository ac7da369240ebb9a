"""Preparing measured heights on plain numpy arrays: detrending (:func:`detrend`,
:func:`level_lines`), filling missing points (:func:`fill_missing`) and finding the largest
window without missing points (:func:`largest_defined_window`). :func:`roughflow.scan.read_scan`
applies them in that order after reading a scan.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from roughflow._jit import njit
from roughflow.defaults import DETREND_MODES, FILL_METHODS
from roughflow.errors import InputError, check_axis

__all__ = ["detrend", "level_lines", "fill_missing", "largest_defined_window"]

def detrend(heights: np.ndarray, lx: float, ly: float, mode: str,
            defined: np.ndarray | None = None) -> np.ndarray:
    """``heights`` minus the least-squares fit of ``mode`` over the ``defined`` points:
    ``"none"`` (nothing removed), ``"plane"`` (mean and tilt), ``"curvature"`` (plane
    plus x^2, xy, y^2), or ``"lines-x"`` / ``"lines-y"`` (:func:`level_lines` along x / y).
    Undefined points get the same correction (their values are whatever they hold)."""
    if mode not in DETREND_MODES:
        raise InputError(f"detrend must be one of {DETREND_MODES}, got {mode!r}")
    if mode == "none":
        return np.array(heights, dtype=np.float64)
    if mode in ("lines-x", "lines-y"):
        return level_lines(heights, 0 if mode == "lines-x" else 1, defined)
    nx, ny = heights.shape
    # coordinates scaled to [-1, 1] keep the normal equations well conditioned
    x = np.linspace(-1.0, 1.0, nx)[:, None] * np.ones((1, ny))
    y = np.ones((nx, 1)) * np.linspace(-1.0, 1.0, ny)[None, :]
    basis = [np.ones_like(x), x, y]
    if mode == "curvature":
        basis += [x * x, x * y, y * y]
    a = np.stack([b.ravel() for b in basis], axis=1)
    ok = np.ones(heights.size, dtype=bool) if defined is None else defined.ravel()
    coef, *_ = np.linalg.lstsq(a[ok], heights.ravel()[ok], rcond=None)
    return heights - (a @ coef).reshape(heights.shape)


def level_lines(heights: np.ndarray, axis: int | str, defined: np.ndarray | None = None
                ) -> np.ndarray:
    """``heights`` with every line along ``axis`` (0: x, 1: y) levelled: each line minus
    the least-squares line (mean and tilt) through its ``defined`` points; a line with one
    defined point loses its height, one with none is left as it is (it is all missing).

    Scanning probes record a topography line by line, and drift between the lines shifts
    and tilts each one; the offsets make grooves along the lines that a plane cannot
    remove. Levelling removes them, and with them whatever the true surface has in the
    lines' means and tilts (its long waves across the lines): use it only along the scan's
    fast axis and only where the line artefacts show."""
    axis = check_axis(axis)
    h = np.array(heights, dtype=np.float64)
    if h.ndim != 2:
        raise InputError(f"heights must be a 2D array, got shape {h.shape}")
    if defined is not None and np.shape(defined) != h.shape:
        raise InputError(f"defined has shape {np.shape(defined)} but the heights have "
                         f"shape {h.shape}")
    lines = np.moveaxis(h, axis, 0)  # a view: (points along a line, lines)
    w = (np.ones(lines.shape) if defined is None else
         np.moveaxis(np.asarray(defined, dtype=bool), axis, 0).astype(np.float64))
    t = np.linspace(-1.0, 1.0, lines.shape[0])[:, None]  # position along the line
    n, st, stt = w.sum(0), (w * t).sum(0), (w * t * t).sum(0)
    known = np.where(w > 0, lines, 0.0)  # undefined points may hold nan
    sh, sth = known.sum(0), (t * known).sum(0)
    det = n * stt - st * st
    tilted = det > 1e-12 * np.maximum(n * n, 1.0)  # at least two distinct defined points
    slope = np.where(tilted, (n * sth - st * sh) / np.where(tilted, det, 1.0), 0.0)
    mean = np.where(n > 0, (sh - slope * st) / np.maximum(n, 1.0), 0.0)
    lines -= mean + slope * t
    return h


def fill_missing(heights: np.ndarray, missing: np.ndarray, method: str) -> np.ndarray:
    """``heights`` with the ``missing`` points filled: ``"harmonic"`` solves Laplace's
    equation on them with the defined neighbours as boundary values (non-periodic, smooth;
    exact for a plane inside the scan, zero normal slope at its edges); ``"min"`` sets them
    to the lowest defined height (open channels: a conservative choice for leakage)."""
    if method not in FILL_METHODS or method == "none":
        raise InputError(f"fill must be one of {FILL_METHODS[1:]}, got {method!r}")
    h = np.array(heights, dtype=np.float64)
    miss = np.asarray(missing, dtype=bool)
    if not miss.any():
        return h
    if miss.all():
        raise InputError("every point of the scan is missing: nothing to fill from")
    if method == "min":
        h[miss] = h[~miss].min()
        return h
    nx, ny = h.shape
    idx = np.full(h.shape, -1, dtype=np.int64)
    cells = np.argwhere(miss)
    idx[miss] = np.arange(len(cells))
    rows, cols, vals = [], [], []
    rhs = np.zeros(len(cells))
    diag = np.zeros(len(cells))
    for dx, dy in ((1, 0), (-1, 0), (0, 1), (0, -1)):
        jx, jy = cells[:, 0] + dx, cells[:, 1] + dy
        inside = (jx >= 0) & (jx < nx) & (jy >= 0) & (jy < ny)
        k = np.flatnonzero(inside)
        diag[k] += 1.0
        nb = idx[jx[k], jy[k]]
        unknown = nb >= 0
        rows.append(k[unknown])
        cols.append(nb[unknown])
        vals.append(-np.ones(int(unknown.sum())))
        np.add.at(rhs, k[~unknown], h[jx[k[~unknown]], jy[k[~unknown]]])
    rows.append(np.arange(len(cells)))
    cols.append(np.arange(len(cells)))
    vals.append(diag)
    m = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                      shape=(len(cells), len(cells)))
    # every 4-connected region of missing points borders a defined point (not all are
    # missing), so the matrix is non-singular
    h[miss] = spla.spsolve(m.tocsc(), rhs)
    return h


@njit(cache=True)
def _largest_rectangle(defined):
    """(points, i0, i1, j0, j1) of the largest all-True rectangle of ``defined``: row by
    row, the runs of defined points ending in each row are a histogram, whose largest
    rectangle a stack of increasing runs finds in one pass (O(nx ny) in all)."""
    nx, ny = defined.shape
    run = np.zeros(ny + 1, np.int64)  # run[ny] stays 0: it empties the stack
    stack = np.empty(ny + 1, np.int64)
    best, i0, i1, j0, j1 = 0, 0, 0, 0, 0
    for i in range(nx):
        for j in range(ny):
            run[j] = run[j] + 1 if defined[i, j] else 0
        top = 0
        for j in range(ny + 1):
            while top > 0 and run[stack[top - 1]] >= run[j]:
                top -= 1
                height = run[stack[top]]
                left = stack[top - 1] + 1 if top > 0 else 0
                if height * (j - left) > best:
                    best, i0, i1, j0, j1 = height * (j - left), i - height + 1, i + 1, left, j
            stack[top] = j
            top += 1
    return best, i0, i1, j0, j1


def largest_defined_window(missing: np.ndarray) -> tuple[slice, slice]:
    """The grid window (slices along x and y) with the most points and no ``missing`` one;
    of equal ones the first in row order. Empty slices if every point is missing."""
    miss = np.asarray(missing, dtype=bool)
    if miss.ndim != 2:
        raise InputError(f"missing must be a 2D mask, got shape {miss.shape}")
    _, i0, i1, j0, j1 = _largest_rectangle(np.ascontiguousarray(~miss))
    return slice(int(i0), int(i1)), slice(int(j0), int(j1))
