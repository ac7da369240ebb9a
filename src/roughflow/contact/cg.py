"""Constrained conjugate gradients on the contact pressure (Polonsky & Keer, Wear 231 (1999)).

Minimises the complementary energy (1/2) p.G p - p.h over p >= 0 with mean(p) = load,
where G is the periodic half-space compliance 2/(|q| E*) (``elastic.compliance``). The
mean of the gap over the contact set is the Lagrange multiplier of the load constraint.
Each iteration costs two FFT pairs (displacement of p and of the search direction).
"""

from __future__ import annotations

import logging

import numpy as np

from roughflow import fft
from roughflow.defaults import SOLVER_LOG_EVERY

from ._linalg import dot as _dot
from ._linalg import height_scale
from ._result import SolverOutput
from .elastic import compliance

log = logging.getLogger(__name__)


def _convolve(plan: fft.RealFFT2, kernel: np.ndarray, a: np.ndarray, out: np.ndarray) -> None:
    c = plan.forward(a)
    c *= kernel
    out[...] = plan.inverse(c)


def polonsky_keer(
    heights: np.ndarray,
    lx: float,
    ly: float,
    load: float,
    *,
    tol: float,
    max_iter: int,
    p0: np.ndarray | None = None,
    threads: int | None = None,
) -> SolverOutput:
    """Solve the frictionless periodic contact under mean pressure ``load``.

    Returns a :class:`SolverOutput` (contact where the pressure is positive). The residual
    is max(max |g - gbar| on the contact set, max overlap off it) / rms(h), where g is
    the gap up to a constant computed from the current pressure: it bounds the local gap
    error in units of the rms height.
    """
    shape = heights.shape
    plan = fft.plan(shape, threads)
    kern = compliance(shape, lx, ly)
    h = heights - heights.mean()
    hscale = height_scale(h.ravel())
    n = h.size
    if p0 is None:
        p = np.full(shape, load)
    else:
        p = np.maximum(np.asarray(p0, dtype=np.float64), 0.0)
        m = p.mean()
        p = p * (load / m) if m > 0 else np.full(shape, load)
    g = np.empty(shape)
    t = np.zeros(shape)
    r = np.empty(shape)
    delta = 0.0
    g_old = 1.0
    residual = np.inf
    it = 0
    gbar = 0.0
    debug = log.isEnabledFor(logging.DEBUG)  # progress every SOLVER_LOG_EVERY iterations
    while True:
        _convolve(plan, kern, p, g)
        g -= h
        s = p > 0
        gbar = float(g[s].mean())
        g -= gbar
        gs = g[s]
        over = g[~s]
        residual = max(float(np.abs(gs).max()), float(-over.min()) if over.size else 0.0)
        residual /= hscale
        if residual <= tol or it >= max_iter:
            break
        if debug and it % SOLVER_LOG_EVERY == 0 and it:
            log.debug("cg iteration %d: residual %.3e (tol %.1e), contact %.4f", it, residual,
                      tol, float(np.count_nonzero(s)) / n)
        it += 1
        gg = _dot(gs, gs)
        t *= delta * gg / g_old
        t += g
        t[~s] = 0.0
        g_old = gg
        _convolve(plan, kern, t, r)
        ts = t[s]
        rs = r[s]
        rs = rs - rs.mean()
        denom = _dot(rs, ts)
        tau = _dot(gs, ts) / denom if denom > 0 else 0.0
        p[s] -= tau * ts
        np.maximum(p, 0.0, out=p)
        ol = (p == 0) & (g < 0)
        if ol.any():
            delta = 0.0
            p[ol] -= tau * g[ol]
        else:
            delta = 1.0
        mp = p.sum() / n
        if mp <= 0:
            p[...] = load
        else:
            p *= load / mp
    gap = np.where(p > 0, 0.0, np.maximum(g, 0.0))
    separation = -gbar  # mean plane of the elastic body relative to mean(h) = 0
    return SolverOutput(pressure=p, gap=gap, contact=p > 0, separation=separation,
                        iterations=it, residual=residual, converged=residual <= tol)
