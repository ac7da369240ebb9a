"""Fused numba loops of the GFMD iterations (one pass over memory instead of five to eight).

``wall_forces`` (``adhesive_wall_forces`` with adhesion), ``reductions``, ``step``: the FIRE
step (``fire.fire``). ``cg_*``: the
projected conjugate-gradient iteration of the hard wall (``gfmd._hard_wall``). ``adhesive_*``:
the line search and the step of the nonlinear CG of the harmonic adhesive model
(``adhesive_cg``); their potential is the one of ``adhesion.Adhesion`` with amp = its
maximum tension, w = pi / rho and kappa = amp w. Each has a
numpy twin (suffix ``_np``, selected by ``gfmd(..., use_numba=False)``) with the same outputs,
used to test the kernels and to benchmark them (docs/contact.md); the hard wall's twins also
run on CuPy arrays, against which ``_cuda_kernels`` (the GPU's fused forms) are tested.
"""

from __future__ import annotations

import math

import numpy as np

from roughflow import fft
from roughflow._jit import njit
from roughflow.gpu import array_module

from .adhesion import Adhesion


@njit(cache=True, nogil=True)
def wall_forces(fel, u, h, eps, load, f, sigma, active):  # pragma: no cover - compiled
    """f = fel - load off the active set, 0 on it; sigma = wall reaction; active mask.

    Active: on the wall (u <= h + eps) with the force pushing into it.
    """
    for i in range(f.size):
        fi = fel[i] - load
        if u[i] <= h[i] + eps and fi < 0.0:
            active[i] = True
            sigma[i] = -fi
            f[i] = 0.0
        else:
            active[i] = False
            sigma[i] = 0.0
            f[i] = fi


#: Taylor coefficients of sin(t) / t in powers of t^2 up to t^22: on [0, pi/2] the first term
#: left out, (pi/2)^25 / 25!, is 4e-21, below the last bit of sin.
_SIN_TAYLOR = tuple((-1.0) ** k / math.factorial(2 * k + 1) for k in range(12))


@njit(cache=True, inline="always")
def _sin_taylor(t):  # pragma: no cover - compiled
    """sin(t) for |t| <= pi/2 by :data:`_SIN_TAYLOR` (Horner in t^2)."""
    z = t * t
    p = _SIN_TAYLOR[11]
    for k in range(10, -1, -1):
        p = p * z + _SIN_TAYLOR[k]
    return t * p


@njit(cache=True, inline="always")
def _sin_half_period(theta):  # pragma: no cover - compiled
    """sin(theta) for theta in [0, pi], reflected to [0, pi/2]: within 2.2e-16 of libm's
    sin there (1 ulp near 1), exactly 0 at pi. Unlike a call to libm it vectorizes: libm's
    (and numpy's) sin costs about 10 ns a cell on the 2-core machines."""
    return _sin_taylor(min(theta, np.pi - theta))


@njit(cache=True, inline="always")
def _cos_half_period(theta):  # pragma: no cover - compiled
    """cos(theta) = sin(pi/2 - theta) for theta in [0, pi], as :func:`_sin_half_period`."""
    return _sin_taylor(0.5 * np.pi - theta)


@njit(cache=True, inline="always")
def _cosine_tension(x, amp, w, rho):  # pragma: no cover - compiled
    """The cosine law's tension -amp sin(w x) at a gap x (clipped at 0) below the range rho,
    0 from rho on (``Adhesion.pressure`` without the repulsion; amp its maximum, w = pi /
    rho): a select gives the 0, since w rho is pi only to an ulp. The compiled adhesive
    kernels all take it; its sine vectorizes (:func:`_sin_half_period`)."""
    return -amp * _sin_half_period(w * min(max(x, 0.0), rho)) if x < rho else 0.0


@njit(cache=True, nogil=True)
def adhesive_wall_forces(fel, u, h, eps, load, amp, w, rho, f, sigma, active,
                         tension):  # pragma: no cover - compiled
    """:func:`wall_forces` with the cosine attraction on the hard wall (``fire.fire``): the
    tension (:func:`_cosine_tension`) at the gap g = max(u - h, 0), added to the elastic
    force ``fel`` before the wall's test and to sigma after it. One vectorized pass instead
    of numpy's dozen (docs/contact.md "Adhesive force pass")."""
    for i in range(f.size):
        t = _cosine_tension(u[i] - h[i], amp, w, rho)
        tension[i] = t
        fi = fel[i] + t - load
        on = u[i] <= h[i] + eps and fi < 0.0
        active[i] = on
        sigma[i] = -fi + t if on else t
        f[i] = 0.0 if on else fi


@njit(cache=True, nogil=True)
def reductions(f, v, a, active):  # pragma: no cover - compiled
    """Zero a and v on the active set; return f.v, v.v, v.a, a.a."""
    fv = 0.0
    vv = 0.0
    va = 0.0
    aa = 0.0
    for i in range(f.size):
        if active[i]:
            a[i] = 0.0
            v[i] = 0.0
        else:
            ai = a[i]
            vi = v[i]
            fv += f[i] * vi
            vv += vi * vi
            va += vi * ai
            aa += ai * ai
    return fv, vv, va, aa


@njit(cache=True, nogil=True)
def step(u, v, a, h, c1, c2, dt):  # pragma: no cover - compiled
    """v = c1 v + c2 a; u += dt v; clip u >= h (zeroing v there)."""
    for i in range(u.size):
        vi = c1 * v[i] + c2 * a[i]
        ui = u[i] + dt * vi
        if ui < h[i]:
            ui = h[i]
            vi = 0.0
        u[i] = ui
        v[i] = vi


#: LLVM may reassociate the sums of the CG kernels (and ignore the sign of zero), which lets
#: it vectorize loops with reductions: 2-2.5x faster update, preconditioning and curvature
#: passes at 1024^2. No NaN or inf assumptions (``tf`` is inf when nothing bounds a step).
#: Sums then differ from a sequential loop's in the last bits, as the numpy twins' do.
#: (A set, not a frozenset: numba accepts only bool, dict or set.)
CG_FASTMATH = {"reassoc", "nsz"}


@njit(cache=True, inline="always")
def _rfft_weight(j, ny):  # pragma: no cover - compiled
    """Multiplicity of rfft2 column j in the full spectrum: the compiled form of
    :func:`roughflow.fft.rfft_weights`."""
    return 1.0 if j == 0 or 2 * j == ny else 2.0


@njit(cache=True, nogil=True, fastmath=CG_FASTMATH)
def cg_update(g, f, d, fks, t, alpha, eps, r, active):  # pragma: no cover - compiled
    """Move the gap g along the trial step s of :func:`cg_direction` (recomputed from d and
    ``alpha``: the same arithmetic) by t: g + t s, where the force is f + t fks with
    fks = -K s (exact up to the transform's round-off: the force is linear in the gap and
    the step does not clip); then the active set (on the wall, force pushing into it) and
    r = f off it, 0 on it (``r`` may be float32: the input of the single-precision
    transforms). Returns sum(r) in double (the load imbalance). t = 0 only classifies
    (after an exact force; d and fks are not read, they may not be set yet)."""
    total = 0.0
    if t != 0.0:
        for i in range(g.size):
            gi = g[i]
            gt = max(gi + alpha * d[i], 0.0)
            gi = max(gi + t * (gt - gi), 0.0)  # max: round-off of a step ending on the wall
            fi = f[i] + t * fks[i]
            g[i] = gi
            f[i] = fi
            on = (gi <= eps) & (fi < 0.0)
            active[i] = on
            ri = 0.0 if on else fi
            r[i] = ri
            total += ri
    else:
        for i in range(g.size):
            fi = f[i]
            on = (g[i] <= eps) & (fi < 0.0)
            active[i] = on
            ri = 0.0 if on else fi
            r[i] = ri
            total += ri
    return total


@njit(cache=True, nogil=True, fastmath=CG_FASTMATH)
def cg_precondition(rt, pre, rt_old, out, ny):  # pragma: no cover - compiled
    """out = rt pre (spectral preconditioning), rt_old = rt; returns r.z and r_old.z by
    Parseval (z = unnormalised inverse transform of out), without a real-space pass.

    Arrays on the rfft2 grid (nx, ny//2+1); ``pre`` carries the 1/(nx ny) of the inverse.
    """
    nx, nh = rt.shape
    rz = 0.0
    roz = 0.0
    for i in range(nx):
        for j in range(nh):
            w = _rfft_weight(j, ny)
            c = rt[i, j]
            p = pre[i, j]
            co = rt_old[i, j]
            out[i, j] = c * p
            # sums in double also for complex64 spectra
            cr = np.float64(c.real)
            ci = np.float64(c.imag)
            rz += w * p * (cr * cr + ci * ci)
            roz += w * p * (np.float64(co.real) * cr + np.float64(co.imag) * ci)
            rt_old[i, j] = c
    return rz, roz


@njit(cache=True, nogil=True, fastmath=CG_FASTMATH)
def cg_direction(z, d, g, f, beta, alpha, s_in, active):  # pragma: no cover - compiled
    """d = z + beta d (0 on the active set); trial gap max(g + alpha d, 0) and the step to
    it, s, into ``s_in`` (the transform's input, float32; :func:`cg_update` recomputes s in
    double instead of storing it). Returns the number of clipped points, f.s, max |z| off
    the active set (a free estimate of the residual) and max |s|."""
    nclip = 0
    fs = 0.0
    zmax = 0.0
    smax = 0.0
    for i in range(g.size):
        on = active[i]
        zi = 0.0 if on else np.float64(z[i])
        zmax = max(zmax, abs(zi))
        di = 0.0 if on else zi + beta * d[i]
        d[i] = di
        gi = g[i]
        gt = gi + alpha * di
        nclip += gt < 0.0
        si = max(gt, 0.0) - gi
        s_in[i] = si
        smax = max(smax, abs(si))
        fs += f[i] * si
    return nclip, fs, zmax, smax


@njit(cache=True, nogil=True, fastmath=CG_FASTMATH)
def cg_feasible(g, d, alpha):  # pragma: no cover - compiled
    """The largest t with g + t s >= 0 for the trial step s of :func:`cg_direction` (inf if
    no point moves towards the wall). Needed only to extrapolate a step that clipped
    nowhere (one iteration in ten), hence a pass of its own."""
    tf = np.inf
    for i in range(g.size):
        gi = g[i]
        si = max(gi + alpha * d[i], 0.0) - gi
        tf = min(tf, gi / -si if si < 0.0 else np.inf)
    return tf


@njit(cache=True, nogil=True, fastmath=CG_FASTMATH)
def cg_stiffness(st, neg_k, out, ny):  # pragma: no cover - compiled
    """out = st neg_k (the transform of -K s, neg_k = -k(q)/N) and s.K s by Parseval on the
    rfft2 grid (``st``: transform of the trial step s), the curvature along the step,
    without a real-space pass; the sum in double also for complex64 spectra."""
    nx, nh = st.shape
    sks = 0.0
    for i in range(nx):
        for j in range(nh):
            w = _rfft_weight(j, ny)
            c = st[i, j]
            k = neg_k[i, j]
            out[i, j] = c * k
            cr = np.float64(c.real)
            ci = np.float64(c.imag)
            sks -= w * np.float64(k) * (cr * cr + ci * ci)
    return sks


@njit(cache=True, nogil=True, fastmath=CG_FASTMATH)
def cg_finish(g, h, f, active, eps, sigma, gap, contact):  # pragma: no cover - compiled
    """The solved state: sigma = wall reaction -f on the active set (0 elsewhere), gap =
    g, zero where in contact (active, or within eps of the wall); returns sum(g + h), the
    sum of the elastic surface's heights."""
    total = 0.0
    for i in range(g.size):
        gi = g[i]
        total += gi + h[i]
        a = active[i]
        c = a | (gi <= eps)
        sigma[i] = -f[i] if a else 0.0
        gap[i] = 0.0 if c else gi
        contact[i] = c
    return total


@njit(cache=True, nogil=True)
def max_abs(a):  # pragma: no cover - compiled
    """max |a| without a temporary array; nan if any element is nan (as numpy's max: a
    residual must not skip a nan and report convergence)."""
    m = 0.0
    for i in range(a.size):
        x = abs(a[i])
        if x > m:
            m = x
        elif x != x:
            return np.nan
    return m


@njit(cache=True, nogil=True)
def max_abs_free(a, active):  # pragma: no cover - compiled
    """max |a| off the active set; nan if any element there is nan."""
    m = 0.0
    for i in range(a.size):
        if not active[i]:
            x = abs(a[i])
            if x > m:
                m = x
            elif x != x:
                return np.nan
    return m


# Capped forms of the hard-wall CG kernels (``gfmd._hard_wall(hardness=H)``, the
# elastic-perfectly-plastic model; gfmd module docstring, "Hardness"). They repeat most of
# their elastic counterparts' loops on purpose: the elastic kernels stay untouched, so the
# elastic solve keeps its bit-identical results and its speed (no extra mask to read or
# write). ``below``: the plastic side (g < -eps, or on the wall with f < -H), whose
# effective force is r = f + H and whose trial gap clips at the kink g = 0 from below; the
# active (stuck) cells are on the wall with -H <= f < 0, their step is 0.


@njit(cache=True, inline="always")
def _side_clip(x, b):  # pragma: no cover - compiled
    """x clipped at the kink from the cell's own side: min(x, 0) below, max(x, 0) above."""
    return min(x, 0.0) if b else max(x, 0.0)


@njit(cache=True, nogil=True, fastmath=CG_FASTMATH)
def cg_update_capped(g, f, d, fks, t, alpha, eps, r, active, below,
                     cap):  # pragma: no cover - compiled
    """:func:`cg_update` with the cap ``cap`` = H: the step s of
    :func:`cg_direction_capped` (0 on the active set, side-clipped elsewhere), then the
    three-way classification (active: on the wall with -H <= f < 0, r = 0; below: r = f + H;
    free: r = f). Returns sum(r)."""
    total = 0.0
    for i in range(g.size):
        gi = g[i]
        b = below[i]
        fi = f[i]
        if t != 0.0:
            si = 0.0 if active[i] else _side_clip(gi + alpha * d[i], b) - gi
            gi = _side_clip(gi + t * si, b)  # round-off of a step ending on the kink
            fi += t * fks[i]
            g[i] = gi
            f[i] = fi
        wall = abs(gi) <= eps
        on = wall & (fi < 0.0) & (fi >= -cap)
        bn = (not on) & ((gi < -eps) | (wall & (fi < -cap)))
        active[i] = on
        below[i] = bn
        ri = 0.0 if on else (fi + cap if bn else fi)
        r[i] = ri
        total += ri
    return total


@njit(cache=True, nogil=True, fastmath=CG_FASTMATH)
def cg_direction_capped(z, d, g, f, beta, alpha, s_in, active, below,
                        cap):  # pragma: no cover - compiled
    """:func:`cg_direction` with the cap: the trial gap clipped at the kink from the cell's
    side (:func:`_side_clip`), s = 0 on the active set, and r.s with r = f + H below (the
    step is exact along s: every cell stays on one piece of the energy)."""
    nclip = 0
    fs = 0.0
    zmax = 0.0
    smax = 0.0
    for i in range(g.size):
        on = active[i]
        b = below[i]
        zi = 0.0 if on else np.float64(z[i])
        zmax = max(zmax, abs(zi))
        di = 0.0 if on else zi + beta * d[i]
        d[i] = di
        gi = g[i]
        gt = gi + alpha * di
        nclip += (not on) & ((gt > 0.0) if b else (gt < 0.0))
        si = 0.0 if on else _side_clip(gt, b) - gi
        s_in[i] = si
        smax = max(smax, abs(si))
        fs += (f[i] + cap if b else f[i]) * si
    return nclip, fs, zmax, smax


@njit(cache=True, nogil=True, fastmath=CG_FASTMATH)
def cg_feasible_capped(g, d, alpha, active, below):  # pragma: no cover - compiled
    """:func:`cg_feasible` with the cap: the largest t before a cell crosses its kink along
    the trial step, from above (g >= 0 falling) or from below (g <= 0 rising)."""
    tf = np.inf
    for i in range(g.size):
        gi = g[i]
        b = below[i]
        si = 0.0 if active[i] else _side_clip(gi + alpha * d[i], b) - gi
        if b:
            tf = min(tf, max(-gi, 0.0) / si if si > 0.0 else np.inf)
        else:
            tf = min(tf, max(gi, 0.0) / -si if si < 0.0 else np.inf)
    return tf


@njit(cache=True, nogil=True, fastmath=CG_FASTMATH)
def cg_finish_capped(g, h, f, active, below, eps, cap, sigma, gap, contact, plastic,
                     depth):  # pragma: no cover - compiled
    """:func:`cg_finish` with the cap: contact = active, or within eps of the wall, or
    below it; the plastic cells (below, in contact) carry H and their depth -g (0
    elsewhere). Returns sum(g + h)."""
    total = 0.0
    for i in range(g.size):
        gi = g[i]
        total += gi + h[i]
        a = active[i]
        c = a | (gi <= eps)
        p = below[i] & c
        sigma[i] = cap if p else (-f[i] if a else 0.0)
        gap[i] = 0.0 if c else gi
        contact[i] = c
        plastic[i] = p
        depth[i] = max(-gi, 0.0) if p else 0.0
    return total


def warm_up() -> None:
    """Compile the kernels (cached on disk after the first run)."""
    n = 4
    z = np.zeros(n)
    b = np.zeros(n, dtype=np.bool_)
    wall_forces(z, z, z, 0.0, 0.0, z.copy(), z.copy(), b)
    reductions(z, z.copy(), z.copy(), b)
    step(z.copy(), z.copy(), z, z, 0.0, 0.0, 0.0)
    z32 = np.zeros(n, dtype=np.float32)
    cg_update(z.copy(), z.copy(), z, z32, 0.0, 0.0, 0.0, z32.copy(), b.copy())
    c = np.zeros((4, 3), dtype=np.complex64)
    cg_precondition(c, np.ones((4, 3)), c.copy(), c.copy(), 4)
    cg_direction(z32, z.copy(), z, z, 0.0, 0.0, z32.copy(), b)
    cg_feasible(z, z, 0.0)
    cg_stiffness(c, np.ones((4, 3), dtype=np.float32), c.copy(), 4)
    cg_finish(z, z, z, b, 0.0, z.copy(), z.copy(), b.copy())
    cg_update_capped(z.copy(), z.copy(), z, z32, 0.0, 0.0, 0.0, z32.copy(), b.copy(),
                     b.copy(), 1.0)
    cg_direction_capped(z32, z.copy(), z, z, 0.0, 0.0, z32.copy(), b, b, 1.0)
    cg_feasible_capped(z, z, 0.0, b, b)
    cg_finish_capped(z, z, z, b, b, 0.0, 1.0, z.copy(), z.copy(), b.copy(), b.copy(),
                     z.copy())
    max_abs(z)
    max_abs_free(z, b)
    adhesive_pressures(z, z.copy(), 1.0, 1.0, 1.0)
    adhesive_line(z, z, 0.0, 1.0, 1.0, 1.0)
    adhesive_move(z.copy(), z, 0.0, z, z.copy(), z.copy(), z, 1.0, 1.0, 1.0)
    adhesive_direction(z, z, 0.0, z.copy(), z.copy(), z, z)


def wall_forces_np(fel, u, h, eps, load, f, sigma, active):
    """numpy version of :func:`wall_forces` (same outputs)."""
    np.subtract(fel, load, out=f)
    np.logical_and(u <= h + eps, f < 0.0, out=active)
    np.copyto(sigma, 0.0)
    sigma[active] = -f[active]
    f[active] = 0.0


def adhesive_wall_forces_np(fel, u, h, eps, load, amp, w, rho, f, sigma, active, tension):
    """numpy version of :func:`adhesive_wall_forces` (same outputs)."""
    g = np.maximum(u - h, 0.0)
    np.copyto(tension, np.where(g < rho, -amp * np.sin(w * g), 0.0))
    wall_forces_np(fel + tension, u, h, eps, load, f, sigma, active)
    np.add(sigma, tension, out=sigma)


def reductions_np(f, v, a, active):
    """numpy version of :func:`reductions`."""
    a[active] = 0.0
    v[active] = 0.0

    def d(x, y):
        return float(np.einsum("i,i->", x, y))

    return d(f, v), d(v, v), d(v, a), d(a, a)


def step_np(u, v, a, h, c1, c2, dt):
    """numpy version of :func:`step`."""
    v *= c1
    v += c2 * a
    u += dt * v
    below = u < h
    u[below] = h[below]
    v[below] = 0.0


def _trial_step(g, d, alpha):
    """The trial step s = max(g + alpha d, 0) - g of :func:`cg_direction` (numpy or CuPy)."""
    s = g + alpha * d
    s = array_module(g).maximum(s, 0.0, out=s)
    s -= g
    return s


def _amax(a) -> float:
    """max(a) as a float, 0 for an empty array (CuPy's max has no ``initial``); nan if any
    element is nan."""
    return float(a.max()) if a.size else 0.0


# The twins below serve the CuPy backend as well (``roughflow.gpu``): they take the array
# module from their arrays and keep every array on its device; floats come back to the host.


def cg_update_np(g, f, d, fks, t, alpha, eps, r, active):
    """numpy (or CuPy) version of :func:`cg_update`."""
    xp = array_module(g)
    if t != 0.0:
        g += t * _trial_step(g, d, alpha)
        xp.maximum(g, 0.0, out=g)
        f += t * fks.astype(xp.float64)
    xp.logical_and(g <= eps, f < 0.0, out=active)
    r[...] = xp.where(active, 0.0, f)
    return float(xp.where(active, 0.0, f).sum())


def cg_precondition_np(rt, pre, rt_old, out, ny):
    """numpy (or CuPy) version of :func:`cg_precondition`."""
    xp = array_module(rt)
    w = xp.asarray(fft.rfft_weights(ny))
    out[...] = rt * pre
    re, im = rt.real.astype(xp.float64), rt.imag.astype(xp.float64)
    wp = w * pre
    rz = float((wp * (re * re + im * im)).sum())
    roz = float((wp * (rt_old.real * re + rt_old.imag * im)).sum())
    rt_old[...] = rt
    return rz, roz


def cg_direction_np(z, d, g, f, beta, alpha, s_in, active):
    """numpy (or CuPy) version of :func:`cg_direction`."""
    xp = array_module(z)
    zfree = xp.where(active, 0.0, z.astype(xp.float64))
    zmax = _amax(xp.abs(zfree))
    d *= beta
    d += zfree
    d[...] = xp.where(active, 0.0, d)
    nclip = int(xp.count_nonzero(g + alpha * d < 0.0))
    s = _trial_step(g, d, alpha)
    s_in[...] = s
    # einsum on the CPU: a BLAS dot oversubscribes shared cores (``_linalg``)
    fs = float(xp.dot(f, s)) if xp is not np else float(np.einsum("i,i->", f, s))
    return nclip, fs, zmax, _amax(xp.abs(s))


def cg_feasible_np(g, d, alpha):
    """numpy (or CuPy) version of :func:`cg_feasible`."""
    xp = array_module(g)
    s = _trial_step(g, d, alpha)
    neg = s < 0.0
    if not bool(neg.any()):
        return np.inf
    return float(xp.where(neg, g / xp.where(neg, -s, 1.0), xp.inf).min())


def cg_stiffness_np(st, neg_k, out, ny):
    """numpy (or CuPy) version of :func:`cg_stiffness`."""
    xp = array_module(st)
    out[...] = st * neg_k
    re, im = st.real.astype(xp.float64), st.imag.astype(xp.float64)
    w = xp.asarray(fft.rfft_weights(ny))
    return -float((w * neg_k.astype(xp.float64) * (re * re + im * im)).sum())


def cg_finish_np(g, h, f, active, eps, sigma, gap, contact):
    """numpy (or CuPy) version of :func:`cg_finish`."""
    xp = array_module(g)
    sigma[...] = xp.where(active, -f, 0.0)
    xp.logical_or(active, g <= eps, out=contact)
    gap[...] = xp.where(contact, 0.0, g)
    return float(g.sum() + h.sum())


def max_abs_np(a):
    """numpy (or CuPy) version of :func:`max_abs`."""
    return _amax(array_module(a).abs(a))


def max_abs_free_np(a, active):
    """numpy (or CuPy) version of :func:`max_abs_free`."""
    xp = array_module(a)
    return _amax(xp.where(active, 0.0, xp.abs(a)))


def _trial_step_capped(g, d, alpha, active, below):
    """The trial step of :func:`cg_direction_capped` (numpy)."""
    x = g + alpha * d
    s = np.where(below, np.minimum(x, 0.0), np.maximum(x, 0.0)) - g
    s[active] = 0.0
    return s


def _classify_capped(g, f, eps, cap, r, active, below) -> float:
    """The three-way classification of :func:`cg_update_capped`; returns sum(r)."""
    wall = np.abs(g) <= eps
    np.logical_and(wall & (f < 0.0), f >= -cap, out=active)
    np.logical_and(~active, (g < -eps) | (wall & (f < -cap)), out=below)
    rr = np.where(active, 0.0, np.where(below, f + cap, f))
    r[...] = rr
    return float(rr.sum())


def cg_update_capped_np(g, f, d, fks, t, alpha, eps, r, active, below, cap):
    """numpy version of :func:`cg_update_capped`."""
    if t != 0.0:
        g += t * _trial_step_capped(g, d, alpha, active, below)
        g[...] = np.where(below, np.minimum(g, 0.0), np.maximum(g, 0.0))
        f += t * fks.astype(np.float64)
    return _classify_capped(g, f, eps, cap, r, active, below)


def cg_direction_capped_np(z, d, g, f, beta, alpha, s_in, active, below, cap):
    """numpy version of :func:`cg_direction_capped`."""
    zfree = np.where(active, 0.0, z.astype(np.float64))
    zmax = _amax(np.abs(zfree))
    d *= beta
    d += zfree
    d[active] = 0.0
    x = g + alpha * d
    nclip = int(np.count_nonzero(~active & np.where(below, x > 0.0, x < 0.0)))
    s = _trial_step_capped(g, d, alpha, active, below)
    s_in[...] = s
    fs = float(np.einsum("i,i->", np.where(below, f + cap, f), s))
    return nclip, fs, zmax, _amax(np.abs(s))


def cg_feasible_capped_np(g, d, alpha, active, below):
    """numpy version of :func:`cg_feasible_capped`."""
    s = _trial_step_capped(g, d, alpha, active, below)
    up = ~below & (s < 0.0)
    dn = below & (s > 0.0)
    tf = np.inf
    if up.any():
        tf = min(tf, float((np.maximum(g[up], 0.0) / -s[up]).min()))
    if dn.any():
        tf = min(tf, float((np.maximum(-g[dn], 0.0) / s[dn]).min()))
    return tf


def cg_finish_capped_np(g, h, f, active, below, eps, cap, sigma, gap, contact, plastic,
                        depth):
    """numpy version of :func:`cg_finish_capped`."""
    np.logical_or(active, g <= eps, out=contact)
    np.logical_and(below, contact, out=plastic)
    sigma[...] = np.where(plastic, cap, np.where(active, -f, 0.0))
    gap[...] = np.where(contact, 0.0, g)
    depth[...] = np.where(plastic, np.maximum(-g, 0.0), 0.0)
    return float(g.sum() + h.sum())


@njit(cache=True, nogil=True)
def adhesive_pressures(g, sigma, amp, w, rho):  # pragma: no cover - compiled
    """sigma = -dv/dg at the gaps g; return the number of points in contact (g < 0). In
    this and the next two kernels every branch is a select and the sine
    :func:`_cosine_tension`'s, so that the loops vectorize (libm's sine, called only within
    the range, had made them a quarter of a harmonic adhesive solve's time)."""
    kappa = amp * w
    n_contact = 0
    for i in range(g.size):
        x = g[i]
        sigma[i] = -kappa * x if x < 0.0 else _cosine_tension(x, amp, w, rho)
        n_contact += x < 0.0
    return n_contact


@njit(cache=True, nogil=True, fastmath=CG_FASTMATH)
def adhesive_line(g, d, t, amp, w, rho):  # pragma: no cover - compiled
    """sum sigma(g + t d) d and sum v''(g + t d) d^2: the interaction's part of the first
    and second derivative of the energy along d (up to sign)."""
    kappa = amp * w
    s1 = 0.0
    s2 = 0.0
    for i in range(g.size):
        di = d[i]
        x = g[i] + t * di
        p = -kappa * x if x < 0.0 else _cosine_tension(x, amp, w, rho)
        c = kappa if x < 0.0 else (kappa * _cos_half_period(w * min(x, rho)) if x < rho
                                   else 0.0)
        s1 += p * di
        s2 += c * di * di
    return s1, s2


@njit(cache=True, nogil=True, fastmath=CG_FASTMATH)
def adhesive_move(g, d, t, kd, f, sigma, z, amp, w, rho):  # pragma: no cover - compiled
    """g += t d; f += sigma(g) - sigma_old - t K d; sigma = sigma(g); return the number of
    points in contact and f.z with the updated f (the old z: Polak-Ribiere's f_new.z_old)."""
    kappa = amp * w
    n_contact = 0
    fz = 0.0
    for i in range(g.size):
        x = g[i] + t * d[i]
        g[i] = x
        s = -kappa * x if x < 0.0 else _cosine_tension(x, amp, w, rho)
        n_contact += x < 0.0
        fi = f[i] + (s - sigma[i] - t * kd[i])
        sigma[i] = s
        f[i] = fi
        fz += fi * z[i]
    return n_contact, fz


@njit(cache=True, nogil=True)
def adhesive_direction(z, kz, beta, d, kd, f, sigma):  # pragma: no cover - compiled
    """d = z + beta d and K d = K z + beta K d; return f.d, sigma.d and d.Kd (the line
    search's coefficients). beta = 0 (a restart) copies z and K z without reading the old
    d, which may be uninitialised memory (0 * nan is nan)."""
    restart = beta == 0.0  # loop-invariant: LLVM unswitches it
    fd = 0.0
    sd = 0.0
    dkd = 0.0
    for i in range(d.size):
        if restart:
            di = z[i]
            kdi = kz[i]
        else:
            di = z[i] + beta * d[i]
            kdi = kz[i] + beta * kd[i]
        d[i] = di
        kd[i] = kdi
        fd += f[i] * di
        sd += sigma[i] * di
        dkd += di * kdi
    return fd, sd, dkd


def _potential_np(amp, rho):
    """The ``Adhesion`` of the kernels' parameters (max tension amp = pi gamma_s / (2 rho))."""
    return Adhesion(surface_energy=2.0 * amp * rho / np.pi, range=rho, repulsion="harmonic")


def adhesive_pressures_np(g, sigma, amp, w, rho):
    """numpy version of :func:`adhesive_pressures`."""
    np.copyto(sigma, _potential_np(amp, rho).pressure(g))
    return int(np.count_nonzero(g < 0.0))


def adhesive_line_np(g, d, t, amp, w, rho):
    """numpy version of :func:`adhesive_line`."""
    potential = _potential_np(amp, rho)
    x = g + t * d
    return (float((potential.pressure(x) * d).sum()),
            float((potential.curvature(x) * d * d).sum()))


def adhesive_move_np(g, d, t, kd, f, sigma, z, amp, w, rho):
    """numpy version of :func:`adhesive_move`."""
    g += t * d
    s = _potential_np(amp, rho).pressure(g)
    f += s - sigma - t * kd
    np.copyto(sigma, s)
    return int(np.count_nonzero(g < 0.0)), float(f @ z)


def adhesive_direction_np(z, kz, beta, d, kd, f, sigma):
    """numpy version of :func:`adhesive_direction`."""
    if beta == 0.0:
        np.copyto(d, z)
        np.copyto(kd, kz)
    else:
        d *= beta
        d += z
        kd *= beta
        kd += kz
    return float(f @ d), float(sigma @ d), float(d @ kd)
