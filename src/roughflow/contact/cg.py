"""Constrained conjugate gradients on the contact pressure (Polonsky & Keer, Wear 231 (1999)).

Minimises the complementary energy (1/2) p.G p - p.h over p >= 0 with mean(p) = load,
where G is the periodic half-space compliance 2/(|q| E*) (``elastic.compliance``). The
mean of the gap over the contact set is the Lagrange multiplier of the load constraint.
Each iteration costs two FFT pairs (displacement of p and of the search direction).

With a ``hardness`` H the pressure is also capped, 0 <= p <= H: the elastic-perfectly-plastic
(saturated pressure) model of Almqvist et al. (Tribol. Int. 40, 2007) and of Tamaas's
``KatoSaturated``. Its optimality conditions give each cell's gap g - gbar a sign: >= 0
where p = 0 (free), = 0 where 0 < p < H (elastic contact), <= 0 where p = H (plastic: the
rigid surface penetrates the elastic surface by the plastic depth gbar - g). It is solved
by an active-set loop on the plastic set around the same iteration (:func:`_capped`).
"""

from __future__ import annotations

import logging

import numpy as np

from roughflow import fft
from roughflow.defaults import CONTACT_PRESSURE_MAX, SOLVER_LOG_EVERY
from roughflow.errors import InputError, require_positive

from ._linalg import dot as _dot
from ._linalg import height_scale
from ._result import SolverOutput
from .elastic import compliance, spectrum_mean

log = logging.getLogger(__name__)

#: Tolerance of the capped solve's intermediate iterations, while its plastic set still
#: changes (the last ones run to the solve's own tol): on 84 test cases (64^2 - 96 x 384,
#: loads 0.01 - 0.2, hardness 1.05 - 50 x the load, tol 1e-8) it cut the iterations by
#: 1.1 - 1.9 x against solving every stage to tol; all converged either way.
_PLASTIC_STAGE_TOL = 1e-3
#: A stage's cells off the plastic set restart from an even share of their load where the
#: warm start would scale their pressures up more than this: the cells that stayed below
#: the cap could be few (one cell carried the load of 138 capped ones and the iteration
#: stalled on it).
_RESTART_SCALE = 2.0


def check_hardness(hardness: float, model: str = "elastic") -> float:
    """``hardness`` as a float: a pressure cap H in E*, positive, finite and at most
    ``CONTACT_PRESSURE_MAX`` (a larger one is a hardness in pascals), for the elastic model
    (the only one with a pressure to cap); :class:`InputError` naming the value otherwise."""
    if isinstance(hardness, (bool, np.bool_)):  # True would pass as 1 E*
        raise InputError(f"hardness must be a pressure (E*), got {hardness!r}")
    h = require_positive("hardness", hardness)
    if h > CONTACT_PRESSURE_MAX:
        raise InputError(
            f"hardness {h:g} E* is above {CONTACT_PRESSURE_MAX:g} E*: hardnesses here are in "
            "units of the contact modulus E* (a steel's 2 GPa against E* = 115 GPa is "
            "0.017); from Python, convert pascals with roughflow.units.Scales.pressure_from_si")
    if model != "elastic":
        why = ("it cuts the heights and has no pressure to cap" if model == "bearing" else
               "the cap is implemented for the hard-wall elastic model only")
        raise InputError(f"hardness={h:g} is for model='elastic', got model={model!r}: {why}")
    return h


def require_below_hardness(load: float, hardness: float, *, load_text: str | None = None,
                           hardness_text: str | None = None) -> None:
    """Refuse a mean pressure ``load`` not below the cap ``hardness`` (the same units): every
    cell would be plastic, and a cap H carries a mean pressure below H only with some cells
    free. ``load_text``, ``hardness_text``: how the caller's user gave the two (an option and
    its value, a pressure in pascals); default the numbers."""
    if load >= hardness:
        raise InputError(
            f"{load_text or f'the mean pressure {load:g}'} is not below "
            f"{hardness_text or f'the hardness {hardness:g}'}: every cell would be plastic "
            "(a cap H carries a mean pressure below H only with some cells free); give a "
            "pressure below the hardness")


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
    hardness: float | None = None,
) -> SolverOutput:
    """Solve the frictionless periodic contact under mean pressure ``load``.

    Returns a :class:`SolverOutput` (contact where the pressure is positive). The residual
    is max(max |g - gbar| on the contact set, max overlap off it) / rms(h), where g is
    the gap up to a constant computed from the current pressure: it bounds the local gap
    error in units of the rms height.

    ``hardness``: cap H of the pressure (units of ``load``), None for none; ``load >=
    hardness`` raises :class:`InputError` (every cell plastic). The contact set of the
    residual is then the elastic one (0 < p < H), and it also counts the positive gap
    max(g - gbar, 0) of every plastic cell (p = H), which should unload. The output's
    ``plastic`` and ``plastic_depth`` (gbar - g on the plastic cells, >= 0) are set; its
    gap is 0 on every contact cell, plastic ones included; ``iterations`` counts those of
    every stage (:func:`_capped`). Where no pressure of the elastic solve reaches the
    hardness, a cold solve's result is the elastic one bit for bit (a warm start ``p0`` is
    rescaled otherwise, so it differs at the tolerance).
    """
    cap = None
    if hardness is not None:
        cap = check_hardness(hardness)
        require_below_hardness(load, cap)
    shape = heights.shape
    plan = fft.plan(shape, threads)
    kern = compliance(shape, lx, ly)
    h = heights - heights.mean()
    hscale = height_scale(h.ravel())
    if p0 is None:
        p = np.full(shape, load)
    elif cap is not None:  # its cells at the cap stay there exactly (_capped scales the rest)
        p = np.clip(np.asarray(p0, dtype=np.float64), 0.0, cap)
    else:
        p = np.maximum(np.asarray(p0, dtype=np.float64), 0.0)
        m = p.mean()
        p = p * (load / m) if m > 0 else np.full(shape, load)
    g = np.empty(shape)
    if cap is not None:
        return _capped(plan, kern, h, hscale, p, g, load, cap, tol, max_iter,
                       warm=p0 is not None)
    it, residual, gbar = _iterate(plan, kern, h, hscale, p, g, load, tol, max_iter)
    gap = np.where(p > 0, 0.0, np.maximum(g, 0.0))
    separation = -gbar  # mean plane of the elastic body relative to mean(h) = 0
    return SolverOutput(pressure=p, gap=gap, contact=p > 0, separation=separation,
                        iterations=it, residual=residual, converged=residual <= tol)


def _iterate(plan: fft.RealFFT2, kern: np.ndarray, h: np.ndarray, hscale: float,
             p: np.ndarray, g: np.ndarray, load: float, tol: float, max_iter: int,
             fixed: np.ndarray | None = None) -> tuple[int, float, float]:
    """The Polonsky-Keer iteration on ``p`` (in place) to ``tol``, at most ``max_iter``
    iterations; ``g`` ends as the centred gap of the final ``p``. Returns (iterations,
    residual, gbar). ``fixed``: cells whose pressure stays as it is (the plastic cells of
    a capped solve): off the active set, the residual and the load's rescaling, which
    gives the other cells the load the fixed ones leave."""
    n = h.size
    some = fixed is not None and bool(fixed.any())  # None or empty: the elastic iteration
    if some:
        movable = ~fixed
        share = n * load - float(p[fixed].sum())
    t = np.zeros(h.shape)
    r = np.empty(h.shape)
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
        if some:
            s &= movable
        gbar = float(g[s].mean())
        g -= gbar
        gs = g[s]
        over = g[~s & movable] if some else g[~s]
        residual = max(float(np.abs(gs).max()), float(-over.min()) if over.size else 0.0)
        residual /= hscale
        if residual <= tol or it >= max_iter:
            break
        if debug and it % SOLVER_LOG_EVERY == 0 and it:
            log.debug("cg iteration %d: residual %.3e (tol %.1e), contact %.4f", it, residual,
                      tol, float(np.count_nonzero(s)) / n)
        it += 1
        gg = _dot(gs, gs)
        # g_old is 0 only where the last active set was one cell (its centred gap is 0)
        t *= delta * gg / g_old if g_old > 0 else 0.0
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
        if some:
            ol &= movable
        if ol.any():
            delta = 0.0
            if tau == 0.0:
                # no step (one active cell, whose centred gap is 0, or no descent): the
                # overlapping cells would never join; each takes the pressure that alone
                # closes its overlap. Seen with a hardness: 20 cells at the cap left the
                # load to one cell, and the residual stayed at 9e-4 for 20000 iterations
                tau = 1.0 / spectrum_mean(kern, h.shape)  # 1 / cell_compliance
            p[ol] -= tau * g[ol]
        else:
            delta = 1.0
        if some:
            carried = float(p[movable].sum())
            if carried <= 0:
                p[movable] = share / np.count_nonzero(movable)
            else:
                p[movable] *= share / carried
            continue
        mp = p.sum() / n
        if mp <= 0:
            p[...] = load
        else:
            p *= load / mp
    return it, residual, gbar


def _capped(plan: fft.RealFFT2, kern: np.ndarray, h: np.ndarray, hscale: float,
            p: np.ndarray, g: np.ndarray, load: float, cap: float, tol: float,
            max_iter: int, warm: bool) -> SolverOutput:
    """The capped solve: an active-set loop on the plastic set P around :func:`_iterate`.

    Each stage solves the contact with the pressure fixed at ``cap`` on P (the elastic
    problem on the other cells, a convex one that the iteration solves as it does without
    a cap); then the cells above the cap join P and the cells of P whose gap is positive
    (they carry too much) leave it, starting at the cap. A stage that adds cells to P never
    leaves the others too little room: each added cell carried more than the cap. The loop
    ends when a stage to ``tol`` changes nothing: the residual then bounds every cell's gap
    error, the plastic ones' included. A cold solve starts with P empty, so its first stage
    is the elastic solve itself (to ``tol``); the next ones run to the looser
    :data:`_PLASTIC_STAGE_TOL` until P settles, the rest to ``tol``. A warm start ``p``
    starts from its cells at the cap.
    """
    n = h.size
    fixed = p >= cap if warm else np.zeros(h.shape, dtype=bool)
    if cap * np.count_nonzero(fixed) >= n * load:  # a start with no room left: from none
        fixed[...] = False
        p[...] = load
    if warm:
        _spread(p, fixed, load, cap)
    stage_tol = tol  # the first stage: the elastic solve of a cold start
    loose = False
    total = 0
    converged = False
    while True:
        it, residual, gbar = _iterate(plan, kern, h, hscale, p, g, load, stage_tol,
                                      max_iter - total, fixed)
        total += it
        if residual > stage_tol:  # the stage ran out of iterations
            break
        above = p > cap
        unload = fixed & (g > stage_tol * hscale)
        if not above.any() and not unload.any():
            if stage_tol <= tol:
                # the plastic cells' gap error enters the residual (each <= tol here)
                up = g[fixed]
                residual = max(residual, float(up.max()) / hscale if up.size else 0.0)
                converged = True
                break
            stage_tol = tol  # P has settled at the loose tolerance: on to tol
            continue
        if total >= max_iter:
            if unload.any():
                residual = max(residual, float(g[unload].max()) / hscale)
            break
        log.debug("cg with hardness: stage of %d iterations, %d cells reach the cap, %d "
                  "unload, %d plastic", it, int(above.sum()), int(unload.sum()),
                  int(fixed.sum()))
        total += 1  # a stage counts at least one iteration: no endless loop of empty stages
        fixed = (fixed | above) & ~unload
        p[above] = cap
        _spread(p, fixed, load, cap)
        if not loose:  # once only: after it, every stage runs to tol
            loose = True
            stage_tol = max(tol, _PLASTIC_STAGE_TOL)
    gap = np.where(p > 0, 0.0, np.maximum(g, 0.0))
    depth = np.where(fixed, np.maximum(-g, 0.0), 0.0)
    return SolverOutput(pressure=p, gap=gap, contact=p > 0, separation=-gbar,
                        iterations=total, residual=residual, converged=converged,
                        plastic=fixed.copy(), plastic_depth=depth)


def _spread(p: np.ndarray, fixed: np.ndarray, load: float, cap: float) -> None:
    """Give the cells off ``fixed`` (the plastic set, at ``cap``) the rest of the load, in
    place: their pressures scaled, or an even share where that would scale them up more
    than :data:`_RESTART_SCALE` (or none carries any)."""
    movable = ~fixed
    count = int(np.count_nonzero(movable))
    share = p.size * load - cap * (p.size - count)  # > 0: fewer than load / cap plastic
    carried = float(p[movable].sum())
    if carried > 0 and share / carried <= _RESTART_SCALE:
        p[movable] *= share / carried
    else:
        p[movable] = share / count
