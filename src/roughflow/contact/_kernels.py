"""Fused numba loops of the GFMD iterations (one pass over memory instead of five to eight).

``wall_forces``, ``reductions``, ``step``: the FIRE step (adhesive model). ``cg_*``: the
projected conjugate-gradient iteration of the hard wall (``gfmd._hard_wall``). Each has a
numpy twin (suffix ``_np``, selected by ``gfmd(..., use_numba=False)``) with the same outputs,
used to test the kernels and to benchmark them (docs/contact.md).
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True, nogil=True)
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


@numba.njit(cache=True, nogil=True)
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


@numba.njit(cache=True, nogil=True)
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


@numba.njit(cache=True, nogil=True)
def cg_update(u, f, s, fks, t, h, eps, r, active):  # pragma: no cover - compiled
    """Move to u + t s, where the force is f + t fks with fks = -K s (exact up to the
    transform's round-off: the force is linear in u and the step does not clip); then the
    active set (on the wall, force pushing into it) and r = f off it, 0 on it (``r`` may be
    float32: the input of the single-precision transforms). Returns sum(r) in double (the
    load imbalance). t = 0 only classifies (after an exact force)."""
    total = 0.0
    move = t != 0.0  # t = 0: s and fks are not read (they may not be set yet)
    for i in range(u.size):
        ui = u[i]
        fi = f[i]
        if move:
            ui += t * s[i]
            if ui < h[i]:  # round-off of a step that ends on the wall
                ui = h[i]
            fi += t * fks[i]
            u[i] = ui
            f[i] = fi
        if ui <= h[i] + eps and fi < 0.0:
            active[i] = True
            r[i] = 0.0
        else:
            active[i] = False
            r[i] = fi
            total += fi
    return total


@numba.njit(cache=True, nogil=True)
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
            w = 1.0 if j == 0 or 2 * j == ny else 2.0  # columns present twice in the spectrum
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


@numba.njit(cache=True, nogil=True)
def cg_direction(z, d, u, h, f, beta, alpha, s_in, s, active):  # pragma: no cover - compiled
    """d = z + beta d (0 on the active set); trial point max(u + alpha d, h) and the step to
    it, s (double), also into ``s_in`` (the transform's input, float32). Returns the number
    of clipped points, f.s, the largest t with u + t s >= h, max |z| off the active set (a
    free estimate of the residual) and max |s|."""
    nclip = 0
    fs = 0.0
    tf = np.inf
    zmax = 0.0
    smax = 0.0
    for i in range(u.size):
        if active[i]:
            di = 0.0
        else:
            zi = np.float64(z[i])
            zmax = max(zmax, abs(zi))
            di = zi + beta * d[i]
        d[i] = di
        ui0 = u[i]
        hi = h[i]
        ui = ui0 + alpha * di
        if ui < hi:
            ui = hi
            nclip += 1
        si = ui - ui0
        s[i] = si
        s_in[i] = si
        smax = max(smax, abs(si))
        fs += f[i] * si
        if si < 0.0 and ui0 - hi < tf * -si:  # divide only when the bound tightens
            tf = (ui0 - hi) / -si
    return nclip, fs, tf, zmax, smax


@numba.njit(cache=True, nogil=True)
def cg_secant(s, fks):  # pragma: no cover - compiled
    """s.K s = -s.fks with fks = -K s: the curvature along the trial step."""
    sks = 0.0
    for i in range(s.size):
        sks -= s[i] * np.float64(fks[i])
    return sks


@numba.njit(cache=True, nogil=True)
def cg_finish(u, h, f, active, eps, sigma, gap, contact):  # pragma: no cover - compiled
    """The solved state: sigma = wall reaction -f on the active set (0 elsewhere), gap =
    u - h, zero where in contact (active, or within eps of the wall); returns sum(u)."""
    total = 0.0
    for i in range(u.size):
        ui = u[i]
        total += ui
        g = ui - h[i]
        a = active[i]
        c = a or g <= eps
        sigma[i] = -f[i] if a else 0.0
        gap[i] = 0.0 if c else g
        contact[i] = c
    return total


@numba.njit(cache=True, nogil=True)
def max_abs(a):  # pragma: no cover - compiled
    """max |a| without a temporary array."""
    m = 0.0
    for i in range(a.size):
        if abs(a[i]) > m:
            m = abs(a[i])
    return m


@numba.njit(cache=True, nogil=True)
def max_abs_free(a, active):  # pragma: no cover - compiled
    """max |a| off the active set."""
    m = 0.0
    for i in range(a.size):
        if not active[i] and abs(a[i]) > m:
            m = abs(a[i])
    return m


def warm_up() -> None:
    """Compile the kernels (cached on disk after the first run)."""
    n = 4
    z = np.zeros(n)
    b = np.zeros(n, dtype=np.bool_)
    wall_forces(z, z, z, 0.0, 0.0, z.copy(), z.copy(), b)
    reductions(z, z.copy(), z.copy(), b)
    step(z.copy(), z.copy(), z, z, 0.0, 0.0, 0.0)
    z32 = np.zeros(n, dtype=np.float32)
    cg_update(z.copy(), z.copy(), z, z32, 0.0, z, 0.0, z32.copy(), b.copy())
    c = np.zeros((4, 3), dtype=np.complex64)
    cg_precondition(c, np.ones((4, 3)), c.copy(), c.copy(), 4)
    cg_direction(z32, z.copy(), z, z, z, 0.0, 0.0, z32.copy(), z.copy(), b)
    cg_secant(z, z32)
    cg_finish(z, z, z, b, 0.0, z.copy(), z.copy(), b.copy())
    max_abs(z)
    max_abs_free(z, b)


def wall_forces_np(fel, u, h, eps, load, f, sigma, active):
    """numpy version of :func:`wall_forces` (same outputs)."""
    np.subtract(fel, load, out=f)
    np.logical_and(u <= h + eps, f < 0.0, out=active)
    np.copyto(sigma, 0.0)
    sigma[active] = -f[active]
    f[active] = 0.0


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


def cg_update_np(u, f, s, fks, t, h, eps, r, active):
    """numpy version of :func:`cg_update`."""
    if t != 0.0:
        u += t * s
        np.maximum(u, h, out=u)
        f += t * fks.astype(np.float64)
    np.logical_and(u <= h + eps, f < 0.0, out=active)
    np.copyto(r, f, casting="same_kind")
    r[active] = 0.0
    return float(np.where(active, 0.0, f).sum())


def cg_precondition_np(rt, pre, rt_old, out, ny):
    """numpy version of :func:`cg_precondition`."""
    nh = rt.shape[1]
    w = np.full(nh, 2.0)
    w[0] = 1.0
    if ny % 2 == 0:
        w[-1] = 1.0
    np.multiply(rt, pre, out=out, casting="same_kind")
    re, im = rt.real.astype(np.float64), rt.imag.astype(np.float64)
    rz = float((w * pre * (re**2 + im**2)).sum())
    roz = float((w * pre * (rt_old.real * re + rt_old.imag * im)).sum())
    np.copyto(rt_old, rt)
    return rz, roz


def cg_direction_np(z, d, u, h, f, beta, alpha, s_in, s, active):
    """numpy version of :func:`cg_direction`."""
    zmax = float(np.abs(np.where(active, 0.0, z)).max(initial=0.0))
    d *= beta
    d += z
    d[active] = 0.0
    np.multiply(d, alpha, out=s)
    s += u
    nclip = int(np.count_nonzero(s < h))
    np.maximum(s, h, out=s)
    s -= u
    np.copyto(s_in, s, casting="same_kind")
    fs = float(np.einsum("i,i->", f, s))
    neg = s < 0.0
    tf = float(((u[neg] - h[neg]) / -s[neg]).min()) if neg.any() else np.inf
    return nclip, fs, tf, zmax, float(np.abs(s).max(initial=0.0))


def cg_secant_np(s, fks):
    """numpy version of :func:`cg_secant`."""
    return -float(np.einsum("i,i->", s, fks.astype(np.float64)))


def cg_finish_np(u, h, f, active, eps, sigma, gap, contact):
    """numpy version of :func:`cg_finish`."""
    np.copyto(sigma, np.where(active, -f, 0.0))
    np.subtract(u, h, out=gap)
    np.logical_or(active, gap <= eps, out=contact)
    gap[contact] = 0.0
    return float(u.sum())


def max_abs_np(a):
    """numpy version of :func:`max_abs`."""
    return float(np.abs(a).max(initial=0.0))


def max_abs_free_np(a, active):
    """numpy version of :func:`max_abs_free`."""
    return float(np.abs(a[~active]).max(initial=0.0))
