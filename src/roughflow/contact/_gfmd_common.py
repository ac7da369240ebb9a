"""What the minimizers of GFMD share: the q = 0 mass, the spectral factors and the residual
(docs/physics.md Sect. 3.2; definitions in the docstring of ``gfmd``)."""

from __future__ import annotations

import functools
from typing import NamedTuple

import numpy as np

from roughflow import fft

from .elastic import cell_compliance, compliance, stiffness

#: q = 0 mass z k_min of m(q) = sqrt((z k_min)^2 + k(q)^2): 3 gave the fewest FIRE steps
#: cold and warm (1, 3, 10, 30, 100).
Z_MASS = 3.0
#: Points of the body and the surface closer than this times rms(h) touch: the round-off of
#: the FFT round trip.
TOUCH_TOL = 1e-12


class SpectralFactors(NamedTuple):
    """Read-only spectral factors of one grid of N points (the 1/N of the unnormalised
    inverse transform folded in)."""

    k: np.ndarray  #: stiffness k(q)
    neg_k_n: np.ndarray  #: -k(q) / N
    compliance_n: np.ndarray  #: G(q) / N
    kmin: float  #: the smallest k > 0


@functools.lru_cache(maxsize=2)  # large grids: 3 spectral arrays each
def spectral_factors(shape: tuple[int, int], lx: float, ly: float) -> SpectralFactors:
    """The :class:`SpectralFactors` of one grid."""
    size = shape[0] * shape[1]
    k = stiffness(shape, lx, ly)
    kmin = float(k[k > 0].min())
    neg_k = k * (-1.0 / size)
    comp = compliance(shape, lx, ly) * (1.0 / size)
    for a in (k, neg_k, comp):
        a.setflags(write=False)
    return SpectralFactors(k, neg_k, comp, kmin)


def load_scale(kmin: float, hscale: float, held: float, floor: float = 0.0) -> float:
    """The pressure the load imbalance |mean f| is measured against: k_min rms(h), which
    moves the longest wave by the rms height (G f has no q = 0 part), or ``held``, the mean
    pressure the contacts hold, where that is smaller and positive, but not below ``floor``:
    the load without adhesion; with it the load plus the mean attraction
    (:func:`held_pressure`), at least :func:`one_cell_scale`.

    The mean separation is then held by the contacts alone, whose stiffness is about the
    pressure they carry over the height scale (p ~ exp(-u / u_0), u_0 ~ rms(h)), far below
    k_min: with k_min rms(h) alone the load at p = 1e-5 was 0.35 % off when the solve
    reported convergence, and with adhesion at zero load (a_c 0.0012, 256^2) the mean gap
    440-530 times tol rms(h) (docs/contact.md "Adhesion at zero load")."""
    scale = kmin * hscale
    if held > 0:
        scale = min(scale, max(held, floor))
    return scale


def one_cell_scale(shape: tuple[int, int], lx: float, ly: float, hscale: float) -> float:
    """The floor of :func:`load_scale` with adhesion: the mean pressure that moves the body's
    mean by ``hscale`` (rms height) against a single cell held in place, 1 / (nx ny
    cell_compliance) times ``hscale``. A body in contact is at least that stiff (every
    further contact stiffens it), while the attraction alone can hold a vanishing pressure:
    a body lifted out of its range kept a tension of 1e-17 (sin(pi) of the cosine law, before
    ``Adhesion.pressure`` ended exactly at the range), and measured against it no solve
    converged."""
    return hscale / (shape[0] * shape[1] * cell_compliance(shape, lx, ly))


def held_pressure(load: float, pressure: np.ndarray) -> float:
    """The mean pressure the contacts hold with adhesion, the ``held`` of :func:`load_scale`:
    ``load`` plus the mean attraction, the negative part of the adhesion's ``pressure``
    (:meth:`~roughflow.contact.adhesion.Adhesion.pressure`), which at equilibrium is the
    mean repulsion (the wall's reaction on the hard wall)."""
    return load - float(np.minimum(pressure, 0.0).mean())


def residual(plan: fft.RealFFT2, ft: np.ndarray, comp_n: np.ndarray, hscale: float,
             scale: float) -> float:
    """max |G f| / rms(h) and the load imbalance |mean f| / ``scale``, the larger of the two.

    ``ft``: the forward transform of f (preserved); ``comp_n``: G(q) / (nx ny), the
    normalisation of the inverse folded in. Uses the plan's inverse buffers.
    """
    np.multiply(ft, comp_n, out=plan.spectral_in)
    displacement = float(np.abs(plan.execute_inverse()).max()) / hscale
    imbalance = abs(float(ft[0, 0].real)) / (plan.shape[0] * plan.shape[1])
    return max(displacement, imbalance / scale)
