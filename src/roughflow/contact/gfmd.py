"""Green's function molecular dynamics with mass weighting and FIRE (docs/physics.md Sect. 3.2).

The elastic surface height u(r) (gap = u - h) moves under the force per unit area

    f = -IFFT(k(q) FFT(u)) - p + f_int(u - h),        k(q) = |q| E*/2,

with the Fourier-space masses of Zhou, Moseler & Mueser (PRB 99, 144103, 2019),
m(q) = sqrt((z k_min)^2 + k(q)^2): the acceleration is a = IFFT(FFT(f) / m(q)), so all
elastic modes share one frequency and the number of steps barely grows with the grid.
The dynamics is damped to the energy minimum by FIRE (Bitzek et al., PRL 97, 170201,
2006), with power f.v and velocity mixing along a.

Hard wall (elastic model). The constraint u >= h is handled by an active set that is
consistent with the non-local mass metric: points on the wall whose force pushes into
it are active; their force (the wall reaction cancels it) and their acceleration and
velocity are set to zero, i.e. the preconditioner is restricted to the free points.
After each step u = max(u, h) with the velocity of clipped points zeroed. A fixed point
has f = 0 off the active set and f <= 0 on it: exactly the contact (KKT) conditions, so
GFMD and CG solve the same discrete problem. Plain projection of a mass-weighted step
(no active set) spuriously detaches points and stalls FIRE (measured: dt -> 0).
Cost: two FFT pairs per step (force, preconditioning).
Adhesive model: the cosine attraction of ``adhesion.Adhesion`` acts on the gap; with
``repulsion="hard"`` the same active-set wall as above, with ``"harmonic"`` no wall.

Residual (checked every ``check_every`` steps, one more inverse FFT): max |G f_eff| / rms(h),
the largest displacement the unbalanced force would still cause, in units of the rms
height (G = compliance 2/(|q| E*)); same units as the CG residual. G has no q = 0 part,
so the load imbalance |mean f_eff| / min(p, k_min rms(h)) enters the maximum as well.
"""

from __future__ import annotations

import logging
import math

import numpy as np

from roughflow import fft
from roughflow.defaults import SOLVER_LOG_EVERY

from . import _kernels as _k
from ._linalg import dot
from ._result import SolverOutput
from .adhesion import Adhesion
from .elastic import compliance, stiffness

# FIRE parameters (Bitzek et al. 2006), time in units of 1/omega of the mass-weighted modes.
# Tuned on 256^2 rough surfaces (a_c 0.1 and 0.4; benchmarks/bench_contact.py): strong
# mixing (alpha_start 0.6) and a gentle dt decrease (0.9) cut the steps to tol 1e-6 from
# about 180 (Bitzek's 0.1 / 0.5) to about 40, independent of the grid size.
DT0 = 0.8
DT_MAX = 1.0
N_MIN = 3
F_INC = 1.1
F_DEC = 0.9
ALPHA0 = 0.6
F_ALPHA = 0.97
# Harmonic adhesive model: the masses stay purely elastic (adding the repulsion stiffness
# kappa to them did not converge on 128^2 surfaces) and the time step is capped lower,
# because the repulsion stiffens the contact points beyond the elastic frequency.
ADHESIVE_DT0 = 0.2
Z_MASS = 3.0  # q = 0 mass z k_min: 3 gave the fewest steps cold and warm (1, 3, 10, 30, 100 tried)

log = logging.getLogger(__name__)


def gfmd(
    heights: np.ndarray,
    lx: float,
    ly: float,
    load: float,
    *,
    tol: float,
    max_iter: int,
    u0: np.ndarray | None = None,
    adhesion: Adhesion | None = None,
    threads: int | None = None,
    check_every: int = 5,
    use_numba: bool = True,
) -> SolverOutput:
    """Minimise elastic + interaction + load energy; returns a :class:`SolverOutput`.

    ``u0``: initial elastic surface height (warm start), default a flat surface touching
    the highest point (or one range above it with adhesion). ``use_numba=False`` runs the
    same step with numpy (for benchmarking the kernels).
    """
    if use_numba:
        wall_forces, reductions, step = _k.wall_forces, _k.reductions, _k.step
    else:
        wall_forces, reductions, step = _k.wall_forces_np, _k.reductions_np, _k.step_np
    shape = heights.shape
    size = heights.size
    plan = fft.plan(shape, threads)
    neg_k = stiffness(shape, lx, ly)  # a new array: negated in place below
    kmin = float(neg_k[neg_k > 0].min())
    comp = compliance(shape, lx, ly)
    h0 = float(heights.mean())
    h = np.ascontiguousarray(heights - h0).ravel()
    hscale = math.sqrt(dot(h, h) / size) or 1.0
    # masses m(q) = sqrt((z k_min)^2 + k^2), kept as 1/m
    inv_mass = np.hypot(Z_MASS * kmin, neg_k)
    soft = adhesion is not None and adhesion.repulsion == "harmonic"
    dt_max = ADHESIVE_DT0 if soft else DT_MAX
    np.reciprocal(inv_mass, out=inv_mass)
    neg_k *= -1.0

    if u0 is not None:
        u = np.asarray(u0, dtype=np.float64).ravel() - h0
    elif not soft:
        u = np.full(size, h.max())
    else:
        u = np.full(size, h.max() + 0.5 * adhesion.range)  # top point at maximum tension
    if not soft:
        np.maximum(u, h, out=u)
    v = np.zeros(size)
    f = np.empty(size)
    sigma = np.empty(size)
    active = np.zeros(size, dtype=bool)
    a = np.empty(size)
    ftc = np.empty(plan.spectral_shape, dtype=complex)
    # mean-force (load) imbalance is measured against the pressure k_min rms(h) that moves
    # the longest wave by the rms height (G f has no q = 0 part), or against the load
    # itself when that is smaller: at small loads a_c ~ p, so the load must hold to tol
    # relative (with k_min rms(h) alone, the load at p = 1e-5 was 0.35 % off when the solve
    # reported convergence)
    load_scale = kmin * hscale
    if adhesion is None and load > 0:
        load_scale = min(load_scale, load)
    eps = 1e-12 * hscale  # round-off of the FFT round trip: points this close touch
    h_clip = np.full(size, -np.inf) if soft else h
    tension = np.zeros(size)

    def forces(check: bool) -> float:
        """Fill f (force off the active set), sigma, active and a = M^-1 f; with ``check``
        also return the residual max |G f| / rms(h) (one extra inverse FFT)."""
        ft = plan.forward(u.reshape(shape))
        ft *= neg_k
        fel = plan.inverse(ft).ravel()
        if adhesion is None:
            wall_forces(fel, u, h, eps, load, f, sigma, active)
        elif not soft:  # hard wall plus cosine tension (<= 0) on the free points
            tension[...] = adhesion.pressure(np.maximum(u - h, 0.0))
            np.add(fel, tension, out=fel)
            wall_forces(fel, u, h, eps, load, f, sigma, active)
            np.add(sigma, tension, out=sigma)
        else:
            sigma[...] = adhesion.pressure(u - h)
            np.add(fel, sigma - load, out=f)
        ft = plan.forward(f.reshape(shape))
        if check:
            np.multiply(ft, comp, out=ftc)
            imbalance = abs(ft[0, 0].real) / size / load_scale
        ft *= inv_mass
        np.copyto(a, plan.inverse(ft).ravel())
        if not check:
            return math.inf
        return max(float(np.abs(plan.inverse(ftc)).max()) / hscale, imbalance)

    dt, alpha, n_pos = (ADHESIVE_DT0 if soft else DT0), ALPHA0, 0
    it = 0
    # progress at DEBUG every SOLVER_LOG_EVERY steps, at the residual checks (the level is
    # read once: the loop itself pays one comparison per check)
    debug = log.isEnabledFor(logging.DEBUG)
    next_log = SOLVER_LOG_EVERY
    res = forces(True)
    while res > tol and it < max_iter:
        it += 1
        fv, vv, va, aa = reductions(f, v, a, active)
        if fv > 0 or vv == 0.0:  # (v = 0 at the start: not an uphill step)
            keep = 1.0
            n_pos += 1
            if n_pos > N_MIN:
                dt = min(dt * F_INC, dt_max)
                alpha *= F_ALPHA
        else:
            keep = 0.0
            n_pos = 0
            dt *= F_DEC
            alpha = ALPHA0
        # v_new = keep v + dt a; FIRE mixing v = (1 - alpha) v_new + alpha |v_new| a / |a|
        vnew = math.sqrt(max(keep * vv + 2 * keep * dt * va + dt * dt * aa, 0.0))
        mix = alpha * vnew / math.sqrt(aa) if aa > 0 else 0.0
        step(u, v, a, h_clip, (1 - alpha) * keep, (1 - alpha) * dt + mix, dt)
        check = it % check_every == 0 or it == max_iter
        r = forces(check)
        if check:
            res = r
            if debug and it >= next_log:
                next_log += SOLVER_LOG_EVERY
                log.debug("gfmd step %d: residual %.3e (tol %.1e), dt %.3g, contact %.4f", it,
                          res, tol, dt, float(np.count_nonzero(active)) / size)
    separation = float(u.mean())
    g = np.subtract(u, h, out=f).reshape(shape)
    if not soft:
        contact = active.reshape(shape) | (g <= eps)
        g[contact] = 0.0
    else:
        contact = g < 0
        np.maximum(g, 0.0, out=g)
    return SolverOutput(pressure=sigma.reshape(shape), gap=g, contact=contact,
                        separation=separation, iterations=it, residual=res,
                        converged=res <= tol)
