"""Nonlinear conjugate gradients for the harmonic adhesive model (docs/contact.md "Adhesion").

Minimises the elastic energy, the interaction v(g) of ``adhesion.Adhesion`` (harmonic
repulsion, cosine attraction) and the load's work over the gap g = u - h, the same energy
and the same residual as mass-weighted FIRE (``fire.fire``), which it replaces for this
model. Each iteration:

1. the preconditioned force z = M^-1 f with the GFMD masses lifted by the mean repulsion
   stiffness, m(q) = sqrt((z k_min)^2 + k^2) + a_c kappa and m(0) = Q0_MASS k_min + a_c kappa
   (below), and K z, both from one forward transform of f; the Polak-Ribiere direction
   d = z + max(beta, 0) d (restarted as d = z when it is not downhill) and K d = K z +
   beta K d by the same recurrence, so d is never transformed;
2. along d the elastic energy is quadratic and the interaction is local, so the line
   minimum phi'(t) = 0 is found by safeguarded Newton steps on sums over the grid
   (``_kernels.adhesive_line``) without another transform;
3. g += t d, and the force is carried: f += sigma(g) - sigma_old - t K d.

Cost per iteration: three transforms (f forward; z and K z inverse), 2-3 passes of the line
search, the step and the direction update (fused kernels that also return the dot products
the next line search and beta need), and one inverse transform per residual check. The
carried force is replaced by the exact one (one FFT pair) before convergence is accepted.

Why not FIRE (docs/contact.md "Adhesion", *Step count at scale*): FIRE's steps grew with
the grid at fixed points per lambda_s (35 / 80 / 180 cold at 512^2 / 1024^2 / 2048^2, and
335 at zero load at 1024^2), with dt at its cap throughout. The calibrated adhesion
keeps rho a fixed fraction of lambda_s, so kappa = pi^2 gamma_s / (2 rho^2) grows about 3x
per doubling of n, while the free surface between patches keeps its long-wave stiffness:
the masses, which know only k(q), leave the problem ever worse conditioned. Lifting the
masses by the grid mean of the repulsion stiffness, a_c kappa, and taking exact steps along
conjugate directions instead of FIRE's fixed dt cut that to 20 / 30 / 55 iterations at
p = 0.11 and 100 instead of 335 at zero load (1024^2; benchmarks/bench_adhesive.py, the same
minima). What is left still grows with n, about as sqrt(kappa).
"""

from __future__ import annotations

import logging
import math

import numpy as np

from roughflow import fft
from roughflow.defaults import CONTACT_CHECK_EVERY, SOLVER_LOG_EVERY
from roughflow.errors import InputError

from . import _kernels as _k
from ._gfmd_common import (
    Z_MASS,
    held_pressure,
    load_scale,
    one_cell_scale,
    residual,
    spectral_factors,
)
from ._linalg import dot, height_scale
from ._result import SolverOutput
from .adhesion import Adhesion

#: Line search: stop where |phi'(t)| <= LINE_TOL |phi'(0)|, after at most LINE_MAX passes.
LINE_TOL = 1e-4
LINE_MAX = 40
#: The masses are lifted by REPULSION_MASS a_c kappa (a_c: fraction of points with g < 0)
#: and rebuilt, restarting the directions, at a residual check where a_c kappa has moved
#: by more than MASS_UPDATE relative.
REPULSION_MASS = 1.0
MASS_UPDATE = 0.25
#: The q = 0 mass is Q0_MASS k_min (plus the lift) instead of FIRE's Z_MASS k_min. The
#: elastic energy has no q = 0 stiffness: the mean separation is held by the interaction
#: alone, whose mean curvature is about a_c kappa, at zero load (a_c ~ 3e-4) 0.07 at
#: 1024^2 against Z_MASS k_min = 9.4, so that mode converged 100x slower than the rest
#: (100 iterations at zero load, 40-55 with 0.1, 1024^2). Smaller is faster still but lets
#: the first steps along the mean separation leave the contact minimum at zero load
#: (0.01: all contact lost at 1024^2, seed 1); 0.1 and 0.03 kept it on every surface tried.
Q0_MASS = 0.1

log = logging.getLogger(__name__)


def adhesive_cg(
    heights: np.ndarray,
    lx: float,
    ly: float,
    load: float,
    *,
    adhesion: Adhesion,
    tol: float,
    max_iter: int,
    u0: np.ndarray | None = None,
    threads: int | None = None,
    check_every: int = CONTACT_CHECK_EVERY,
    use_numba: bool = True,
) -> SolverOutput:
    """Minimise with the harmonic ``adhesion``; arguments and result as ``gfmd.gfmd``
    (``iterations`` counts CG iterations, the residual is checked every ``check_every``)."""
    if adhesion.repulsion != "harmonic":
        raise InputError(f"adhesive_cg needs the harmonic repulsion, got {adhesion.repulsion!r}")
    if use_numba:
        pressures, line = _k.adhesive_pressures, _k.adhesive_line
        move, direction = _k.adhesive_move, _k.adhesive_direction
    else:
        pressures, line = _k.adhesive_pressures_np, _k.adhesive_line_np
        move, direction = _k.adhesive_move_np, _k.adhesive_direction_np
    shape = heights.shape
    size = heights.size
    plan = fft.plan(shape, threads)
    k, neg_k_n, comp_n, kmin = spectral_factors(tuple(shape), float(lx), float(ly))
    base_mass = np.hypot(Z_MASS * kmin, k)
    base_mass[0, 0] = Q0_MASS * kmin
    inv_mass_n = np.empty_like(base_mass)
    h0 = float(heights.mean())
    h = np.ascontiguousarray(heights - h0, dtype=np.float64).ravel()
    hscale = height_scale(h)
    floor = one_cell_scale(tuple(shape), float(lx), float(ly), hscale)
    amp, rho = adhesion.max_tension, adhesion.range
    w = math.pi / rho
    kappa = adhesion.kappa

    if u0 is not None:
        g = np.asarray(u0, dtype=np.float64).ravel() - h0 - h
    else:
        g = (h.max() + 0.5 * rho) - h  # top point at maximum tension
    sigma = np.empty(size)
    f = np.empty(size)
    kd = np.empty(size)
    z = np.empty(size)
    kz = np.empty(size)
    stiff_over_mass_n = np.empty_like(base_mass)
    d = np.empty(size)
    real_in = plan.real_in.reshape(-1)

    def exact_force() -> int:
        """f = -K u + sigma(g) - load from scratch; return the points in contact."""
        n_contact = pressures(g, sigma, amp, w, rho)
        np.add(g, h, out=real_in)
        np.multiply(plan.execute_forward(), neg_k_n, out=plan.spectral_in)
        np.add(sigma, plan.execute_inverse().reshape(-1), out=f)
        np.subtract(f, load, out=f)
        return n_contact

    def set_masses(lift: float) -> None:
        np.add(base_mass, lift, out=inv_mass_n)
        np.reciprocal(inv_mass_n, out=inv_mass_n)
        np.multiply(inv_mass_n, 1.0 / size, out=inv_mass_n)
        np.multiply(inv_mass_n, k, out=stiff_over_mass_n)

    def precondition(check: bool) -> float:
        """z = M^-1 f and kz = K z from one forward transform of f; with ``check`` also
        return the residual (else inf)."""
        real_in[:] = f
        ft = plan.execute_forward()  # preserved by the inverses below
        res = math.inf
        if check:
            scale = load_scale(kmin, hscale, held_pressure(load, sigma), floor)
            res = residual(plan, ft, comp_n, hscale, scale)
        np.multiply(ft, inv_mass_n, out=plan.spectral_in)
        np.copyto(z, plan.execute_inverse().reshape(-1))
        np.multiply(ft, stiff_over_mass_n, out=plan.spectral_in)
        np.copyto(kz, plan.execute_inverse().reshape(-1))
        return res

    def restart(check: bool) -> tuple[float, float, tuple[float, float, float]]:
        """d = z (and K d = K z) from the present force: residual, f.z (= f.d), line
        coefficients."""
        res = precondition(check)
        coefficients = direction(z, kz, 0.0, d, kd, f, sigma)
        return res, coefficients[0], coefficients

    lift = REPULSION_MASS * kappa * exact_force() / size
    set_masses(lift)
    res, rz, coefficients = restart(True)
    exact = True  # f is the exact force, not the carried one
    t = 1.0
    it = 0
    debug = log.isEnabledFor(logging.DEBUG)
    next_log = SOLVER_LOG_EVERY
    n_contact = 0
    while True:
        if res <= tol:
            if exact:
                break
            # accept only on the exact force (the carried one drifts by round-off)
            exact_force()
            res, rz, coefficients = restart(True)
            exact = True
            continue
        if it >= max_iter or math.isnan(res):  # a nan never recovers: report it at once
            break
        it += 1
        fd, sd, dkd = coefficients
        if fd <= 0.0:  # not downhill (beta too large for the nonlinear energy): restart
            fd, sd, dkd = direction(z, kz, 0.0, d, kd, f, sigma)
        t = _line_minimum(line, g, d, fd - sd, dkd, -fd, t, amp, w, rho)
        n_contact, fz_old = move(g, d, t, kd, f, sigma, z, amp, w, rho)
        exact = False
        check = it % check_every == 0 or it == max_iter
        new_lift = REPULSION_MASS * kappa * n_contact / size
        if check and abs(new_lift - lift) > MASS_UPDATE * max(new_lift, lift):
            lift = new_lift
            set_masses(lift)
            res, rz, coefficients = restart(True)
        else:
            r = precondition(check)
            if check:
                res = r
            fz = dot(f, z)
            beta = max((fz - fz_old) / rz, 0.0) if rz > 0 else 0.0
            rz = fz
            # K d by the same recurrence as d: no transform of d
            coefficients = direction(z, kz, beta, d, kd, f, sigma)
        if check and load < 0 and float(g.min()) >= rho:
            # under tension with every point beyond the attraction's range nothing holds
            # the body: each line search pulls it further off (past the pull-off force the
            # gaps grew to 4e14 in 50 iterations, then overflowed to nan); no equilibrium
            # is left to find, so stop here with finite gaps
            break
        if debug and check and it >= next_log:
            next_log += SOLVER_LOG_EVERY
            log.debug("adhesive cg iteration %d: residual %.3e (tol %.1e), step %.3g, "
                      "contact %.4f", it, res, tol, t, n_contact / size)
    separation = float(g.mean()) + float(h.mean())
    contact = adhesion.contact_mask(g, g < 0).reshape(shape)
    gap = np.maximum(g, 0.0, out=f).reshape(shape)
    gap[contact] = 0.0  # a contact cell is closed (adhesion.Adhesion)
    return SolverOutput(pressure=sigma.reshape(shape), gap=gap, contact=contact,
                        separation=separation, iterations=it, residual=res,
                        converged=res <= tol)


def _line_minimum(line, g, d, a, dkd, slope0, t, amp, w, rho) -> float:
    """The first minimum t > 0 of the energy along d, from the guess ``t``.

    phi'(t) = -(a - t d.Kd + sum sigma(g + t d) d) with a = (f - sigma).d, and
    phi''(t) = d.Kd + sum v''(g + t d) d^2; ``slope0`` = phi'(0) < 0. Newton steps inside
    the bracket [lo, hi] (phi' < 0 at lo, > 0 at hi), bisection when a step leaves it,
    doubling until phi' turns positive.
    """
    lo, hi = 0.0, math.inf
    for _ in range(LINE_MAX):
        s1, s2 = line(g, d, t, amp, w, rho)
        slope = -(a - t * dkd + s1)
        if abs(slope) <= LINE_TOL * abs(slope0):
            return t
        if slope < 0.0:
            lo = t
        else:
            hi = t
        curv = dkd + s2
        newton = t - slope / curv if curv > 0.0 else math.nan
        if math.isinf(hi):
            t = newton if newton > t else 2.0 * t
        else:
            t = newton if lo < newton < hi else 0.5 * (lo + hi)
    return lo if lo > 0.0 else t
