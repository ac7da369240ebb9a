"""What the minimizers of GFMD share: the q = 0 mass, the spectral factors and the residual
(docs/physics.md Sect. 3.2; definitions in the docstring of ``gfmd``)."""

from __future__ import annotations

import functools
from typing import NamedTuple

import numpy as np

from roughflow import fft

from .elastic import compliance, stiffness

#: q = 0 mass z k_min of m(q) = sqrt((z k_min)^2 + k(q)^2): 3 gave the fewest FIRE steps
#: cold and warm (1, 3, 10, 30, 100).
Z_MASS = 3.0


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


def load_scale(kmin: float, hscale: float, load: float, adhesive: bool) -> float:
    """The pressure the load imbalance |mean f| is measured against: k_min rms(h), which
    moves the longest wave by the rms height (G f has no q = 0 part), or the load itself
    when that is smaller and there is no adhesion: at small loads a_c ~ p, so the load must
    hold to tol relative (with k_min rms(h) alone, the load at p = 1e-5 was 0.35 % off when
    the solve reported convergence)."""
    scale = kmin * hscale
    if not adhesive and load > 0:
        scale = min(scale, load)
    return scale


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
