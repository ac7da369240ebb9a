"""Fused numba loops of the GFMD step (one pass over memory instead of five to eight).

Measured in benchmarks/bench_contact.py against the numpy version of the same step
(``ROUGHFLOW_CONTACT_NUMBA=0`` selects numpy): see docs/contact.md.
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


def warm_up() -> None:
    """Compile the kernels (cached on disk after the first run)."""
    n = 4
    z = np.zeros(n)
    b = np.zeros(n, dtype=np.bool_)
    wall_forces(z, z, z, 0.0, 0.0, z.copy(), z.copy(), b)
    reductions(z, z.copy(), z.copy(), b)
    step(z.copy(), z.copy(), z, z, 0.0, 0.0, 0.0)


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
