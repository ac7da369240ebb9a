"""Mass-weighted FIRE for the adhesive model on the hard wall (docs/contact.md "Adhesion").

FIRE (Bitzek et al., PRL 97, 170201, 2006) in the metric of the Fourier-space masses of
Zhou, Moseler & Mueser (PRB 99, 144103, 2019), m(q) = sqrt(m_0^2 + k(q)^2), with
m_0 = z k_min (at q = 0 :func:`adhesive_q0_mass`), the power f.v and velocity mixing along
the acceleration, the cosine attraction acting on the free points of the active-set wall
(velocity zeroed on the active set, u = max(u, h) after each step), the time step capped by
:func:`stable_step`. ``gfmd.gfmd`` dispatches here for ``adhesion=`` with the hard wall (the
default ``repulsion="hard"``), and for ``minimizer="fire"`` on the hard wall without
adhesion and on the harmonic repulsion (without a wall), as before ``adhesive_cg``. The
contact mask is the adhesion's (``Adhesion.contact_mask``), and a contact cell's gap is set
to zero. Residual and checks: ``gfmd`` module docstring, "Residual".
"""

from __future__ import annotations

import logging
import math

import numpy as np

from roughflow import fft
from roughflow.defaults import CONTACT_CHECK_EVERY, SOLVER_LOG_EVERY

from . import _kernels as _k
from ._gfmd_common import (
    TOUCH_TOL,
    Z_MASS,
    held_pressure,
    load_scale,
    one_cell_scale,
    residual,
    spectral_factors,
)
from ._linalg import height_scale
from ._result import SolverOutput
from .adhesion import Adhesion
from .elastic import stiffness

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
# Harmonic adhesive model under FIRE: the masses stay purely elastic (adding the repulsion stiffness
# kappa to them did not converge on 128^2 surfaces) and the time step is capped lower,
# because the repulsion stiffens the contact points beyond the elastic frequency.
ADHESIVE_DT0 = 0.2
# Hard wall with adhesion: the q = 0 mass is ADHESIVE_Q0_MASS k_min at zero (or negative)
# load and rises linearly to Z_MASS k_min at the load k_min rms(h) x ADHESIVE_Q0_RAMP
# (:func:`adhesive_q0_mass`). At zero load only the few adhesive contacts hold the mean
# separation, and that mode converges last under the heavier mass; under load the contacts on
# the wall hold it, and the lighter mass costs steps. Measured on the paper's adhesive case
# (512^2, seeds 0 and 1; zero load, p10/8, p40/4 warm-started to tol 1e-5, then cold solves
# at 0.003, p10/8 and p40/4 and a warm chain of four load steps of 1-4 % to tol 1e-4):
# 325-335 and 525-540 steps in all with the ramp (its width 0.5, 1 or 2 alike), against
# 470 and 655 with 1 k_min throughout and 510 and 910 with 3 k_min throughout (zero load:
# 70 / 260 steps with 1 k_min, 275 / 665 with 3; a warm load step: 25-30 with 3, 45-50
# with 1); the same minima.
ADHESIVE_Q0_MASS = 1.0
ADHESIVE_Q0_RAMP = 1.0

log = logging.getLogger(__name__)


def fire(
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
    check_every: int = CONTACT_CHECK_EVERY,
    use_numba: bool = True,
) -> SolverOutput:
    """Mass-weighted FIRE (the adhesive model); arguments as :func:`.gfmd.gfmd`."""
    if use_numba:
        wall_forces, reductions, step = _k.wall_forces, _k.reductions, _k.step
        adhesive_wall_forces = _k.adhesive_wall_forces
    else:
        wall_forces, reductions, step = _k.wall_forces_np, _k.reductions_np, _k.step_np
        adhesive_wall_forces = _k.adhesive_wall_forces_np
    shape = heights.shape
    size = heights.size
    plan = fft.plan(shape, threads)
    neg_k = stiffness(shape, lx, ly)  # a new array: negated in place below
    kmin = float(neg_k[neg_k > 0].min())
    comp_n = spectral_factors(shape, lx, ly).compliance_n
    h0 = float(heights.mean())
    h = np.ascontiguousarray(heights - h0, dtype=np.float64).ravel()
    hscale = height_scale(h)
    # masses m(q) = sqrt((z k_min)^2 + k^2), kept as 1/m
    inv_mass = np.hypot(Z_MASS * kmin, neg_k)
    soft = adhesion is not None and adhesion.repulsion == "harmonic"
    floor = 0.0 if adhesion is None else one_cell_scale(shape, lx, ly, hscale)
    dt_max = ADHESIVE_DT0 if soft else DT_MAX
    if adhesion is not None and not soft:
        inv_mass.flat[0] = adhesive_q0_mass(load, kmin, hscale)
        dt_max = min(dt_max, stable_step(inv_mass, neg_k, adhesion.kappa))
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
    eps = TOUCH_TOL * hscale
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
            adhesive_wall_forces(fel, u, h, eps, load, adhesion.max_tension,
                                 math.pi / adhesion.range, adhesion.range, f, sigma, active,
                                 tension)
        else:
            sigma[...] = adhesion.pressure(u - h)
            np.add(fel, sigma - load, out=f)
        ft = plan.forward(f.reshape(shape))
        res = math.inf
        if check:
            held = load if adhesion is None else held_pressure(load, sigma if soft else tension)
            res = residual(plan, ft, comp_n, hscale, load_scale(kmin, hscale, held, floor))
        ft *= inv_mass
        np.copyto(a, plan.inverse(ft).ravel())
        return res

    dt, alpha, n_pos = min(ADHESIVE_DT0 if soft else DT0, dt_max), ALPHA0, 0
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
                touching = np.count_nonzero(_fire_contact(u - h, active, eps, adhesion))
                log.debug("gfmd step %d: residual %.3e (tol %.1e), dt %.3g, contact %.4f", it,
                          res, tol, dt, touching / size)
    separation = float(u.mean())
    g = np.subtract(u, h, out=f).reshape(shape)
    contact = _fire_contact(g, active.reshape(shape), eps, adhesion)
    np.maximum(g, 0.0, out=g)
    g[contact] = 0.0  # a contact cell is closed (adhesion.Adhesion)
    return SolverOutput(pressure=sigma.reshape(shape), gap=g, contact=contact,
                        separation=separation, iterations=it, residual=res,
                        converged=res <= tol)


def stable_step(mass: np.ndarray, k: np.ndarray, kappa: float) -> float:
    """The largest FIRE time step at which velocity Verlet stays stable for every mode of the
    hard wall with adhesion: 2 / omega_max, omega^2 = (k(q) + kappa) / m(q), with kappa the
    attraction's largest curvature (:attr:`Adhesion.kappa`), as if every cell sat where it
    peaks. The masses ``mass`` hold only the elastic stiffness ``k``; where the attraction is
    stiff against them (short range, a high Tabor parameter) the steps of DT_MAX overshot:
    cold solves at tensile loads well inside the pull-off range moved off to infinity, full
    contact was left under a load step of +0.05 p* (a sinusoid, 4096 points, range 0.05 of
    its amplitude: a 0.12 cap). The bound takes every cell at the peak curvature, so it is
    conservative: on the paper's adhesive surface (512^2, kappa 31 = 10 k_min) it caps the
    step at 0.64, and a solve at zero load takes 115 steps instead of 80 (a 9-solve ladder
    510 against 480, the same areas); at gamma = 16 (kappa 3.6) the cap, 1.87, leaves
    DT_MAX in force."""
    return float(2.0 * np.sqrt(np.min(mass / (k + kappa))))


def adhesive_q0_mass(load: float, kmin: float, hscale: float) -> float:
    """The q = 0 mass of FIRE on the hard wall with adhesion at ``load``: ADHESIVE_Q0_MASS k_min
    at zero or negative load, rising linearly to Z_MASS k_min at the load
    ADHESIVE_Q0_RAMP k_min ``hscale`` (rms height), constant beyond."""
    x = min(max(load / (ADHESIVE_Q0_RAMP * kmin * hscale), 0.0), 1.0)
    return (ADHESIVE_Q0_MASS + x * (Z_MASS - ADHESIVE_Q0_MASS)) * kmin


def _fire_contact(g: np.ndarray, active: np.ndarray, eps: float,
                  adhesion: Adhesion | None) -> np.ndarray:
    """The contact mask of a FIRE state with gap ``g``: on the wall (``active`` or within
    ``eps`` of it), overlapping the harmonic wall (which has no active set), or inside the
    adhesion's contact gap."""
    if adhesion is not None and adhesion.repulsion == "harmonic":
        return adhesion.contact_mask(g, g < 0)
    touching = active | (g <= eps)
    return touching if adhesion is None else adhesion.contact_mask(g, touching)
