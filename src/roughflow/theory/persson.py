"""Persson contact theory from the height spectrum: a_c(p), the elastic energy, the mean gap.

Units: E* = ``modulus`` (default 1), lengths in L, pressures in E* (for the project's
surfaces with rms gradient 1 that is E* gbar).

Spectrum. Persson's isotropic C(q) enters only through integrals int dq q^n C(q) g(q).
On the periodic cell they are evaluated as sums over the discrete Fourier modes:
int dq q^n C(q) g(q) = (1/2 pi) sum_q |q|^(n-1) |h_q|^2 g(|q|), with h(r) =
sum_q h_q exp(i q r) (so sum_q |h_q|^2 = <h^2>, sum_q q^2 |h_q|^2 = gbar^2). A
:class:`~roughflow.surface.SurfaceSpec` gives |h_q|^2 = C(q_P) on its grid (normalised to
its rms gradient, the amplitudes that ``generate`` uses); a
:class:`~roughflow.surface.Surface` gives its own |h_q|^2, a non-periodic scan that of its
mirror-tiled 2 x 2 cell (its wrap-around step would add a q^-2 tail: on a 512^2 AFM scan
gbar 1.39 instead of 0.91, docs/theory.md). Anisotropic spectra are
treated through |q| only (Persson's isotropic theory).

Formulas implemented (Persson, J. Chem. Phys. 115, 3840 (2001); Persson, PRL 99,
125502 (2007); Yang & Persson, J. Phys.: Condens. Matter 20, 215214 (2008), Eq. 9-12;
Almqvist et al., JMPS 59, 2355 (2011)):

* magnification-dependent inverse rms slope
  w(q) = (pi int_{q0}^{q} dq' q'^3 C(q'))^(-1/2) = (sum_{|q'|<=q} q'^2 |h_q'|^2 / 2)^(-1/2)
  (midpoint rule: a shell of equal |q| counts half of itself);
* contact area at magnification q: P(q, p) = erf(w(q) p / E*); at the full
  resolution w = sqrt(2)/gbar, so a_c(p) = erf(sqrt(2) p/(E* gbar)), small-load
  slope sqrt(8/pi) = 1.596 in units of E* gbar (:func:`persson_area`);
* stored elastic energy per unit area with the correction factor gamma_P
  (``energy_factor``, 0.42 as in Yang & Persson 2008):
  U_el(p) = (pi E*/2) int dq q^2 C(q) P(q,p) [gamma_P + (1 - gamma_P) P(q,p)^2];
* mean gap from p = -dU_el/du, i.e. u(p) = int_p^inf dp'/p' dU_el/dp':
  u(p) = sqrt(pi) int dq q^2 C(q) w(q) int_p^inf dp'/p' [gamma_P + 3(1-gamma_P) P^2]
         exp(-(w p'/E*)^2)
       = (1/(2 sqrt(pi))) sum_q |q| |h_q|^2 w(q) J(w(q) p/E*),
  J(t0) = gamma_P E1(t0^2)/2 + 3 (1 - gamma_P) int_t0^inf erf(t)^2 exp(-t^2) dt/t.
  At small p, J ~ -gamma_P ln t0, hence u = -u0 ln p + const, i.e. p ~ exp(-u/u0) with
  u0 = (gamma_P / (2 sqrt(pi))) sum_q |q| |h_q|^2 w(q) (:func:`persson_u0`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import TYPE_CHECKING

import numpy as np
from scipy.integrate import cumulative_simpson
from scipy.special import erf, exp1

from roughflow import fft
from roughflow._repr import summary_repr
from roughflow.defaults import DEFAULT_MODEL, PERSSON_ENERGY_FACTOR
from roughflow.errors import InputError, require_field, require_positive
from roughflow.surface import (
    Surface,
    SurfaceSpec,
    mirror_tiled,
    spec_power,
)

from .closed_form import closed_form
from .effective_medium import _wsum

if TYPE_CHECKING:
    from numpy.typing import ArrayLike


@dataclass(frozen=True)
class DiscreteSpectrum:
    """Shells of equal |q| (ascending): ``q`` (1/L), ``power`` = sum of |h_q|^2 in the shell (L^2),
    ``w`` = w(q) of the module doc (dimensionless); ``rms_slope`` = sqrt(sum q^2 |h_q|^2)."""

    q: np.ndarray
    power: np.ndarray
    w: np.ndarray
    rms_slope: float


@dataclass(frozen=True)
class PerssonPrediction:
    """sigma(p) from the spectrum alone: Persson a_c(p) and u(p) inserted into Eq. (16).

    pressure (E*), area_fraction, mean_gap (L), sigma (L^3/eta), kind, a_c_star.
    """

    __repr__ = summary_repr

    pressure: np.ndarray
    area_fraction: np.ndarray
    mean_gap: np.ndarray
    sigma: np.ndarray
    kind: str
    a_c_star: float


def discrete_spectrum(source: SurfaceSpec | Surface) -> DiscreteSpectrum:
    """Shell-summed discrete spectrum |h_q|^2 of a spec (deterministic amplitudes) or a surface."""
    from roughflow.resources import check_memory

    if isinstance(source, SurfaceSpec):
        q, power = spec_power(source)  # weighted, normalised to the spec's rms slope
        q, power = q.ravel(), power.ravel()
    elif isinstance(source, Surface):
        h = require_field("heights", source.heights)
        lx, ly = source.lx, source.ly
        if not source.periodic:  # a scan: its wrap-around step would add a q^-2 tail
            check_memory("spectrum", (2 * h.shape[0], 2 * h.shape[1]),
                         what="the Persson spectrum of a scan's mirror-tiled cell")
            h, lx, ly = mirror_tiled(h), 2 * lx, 2 * ly
        nx, ny = h.shape
        qx, qy = fft.wavevectors(nx, ny, lx, ly)
        q = np.sqrt(qx**2 + qy**2) * np.ones((1, ny // 2 + 1))
        power = np.abs(fft.rfft2(h - h.mean()) / (nx * ny)) ** 2 * fft.rfft_weights(ny)
        q, power = q.ravel(), power.ravel()
    else:
        raise InputError(
            f"expected a SurfaceSpec or a Surface, got {type(source).__name__}"
        )
    keep = (q > 0) & (power > 0)
    q, power = q[keep], power[keep]
    if q.size == 0:
        raise InputError("the spectrum has no modes with q > 0")
    m2 = source.rms_slope**2 if isinstance(source, SurfaceSpec) else float(_wsum(q * q, power))
    key = np.round(q / q.max(), 12)
    uniq, inv = np.unique(key, return_inverse=True)
    p_shell = np.bincount(inv, weights=power)
    q_shell = np.bincount(inv, weights=q) / np.bincount(inv)
    m2_shell = q_shell**2 * p_shell
    cum = np.cumsum(m2_shell) - 0.5 * m2_shell
    w = 1.0 / np.sqrt(0.5 * cum)
    return DiscreteSpectrum(q=q_shell, power=p_shell, w=w, rms_slope=math.sqrt(m2))


def _as_spectrum(source) -> DiscreteSpectrum:
    return source if isinstance(source, DiscreteSpectrum) else discrete_spectrum(source)


def _pressures(pressure, modulus: float) -> np.ndarray:
    """``pressure`` (in the units of ``modulus``) as an array, refused where not finite and
    positive, or beyond any linear-elastic contact (a pressure in pascals with modulus 1)."""
    from roughflow.contact import check_pressure_scale

    p = np.asarray(pressure, dtype=np.float64)
    if not np.isfinite(p).all() or (p <= 0).any():
        raise InputError(f"pressure must be finite and > 0, got {pressure!r}")
    check_pressure_scale(p / modulus)
    return p


def _check_factor(energy_factor: float) -> float:
    g = float(energy_factor)
    if not 0.0 < g <= 1.0:
        raise InputError(f"energy_factor must lie in (0, 1], got {energy_factor!r}")
    return g


def persson_area(pressure: ArrayLike, rms_slope: float = 1.0, *,
                 modulus: float = 1.0) -> np.ndarray | float:
    """Persson's relative contact area a_c(p) = erf(sqrt(2) p/(E* gbar)).

    Small-load slope da_c/dp = sqrt(8/pi)/(E* gbar) = 1.596/(E* gbar). ``pressure`` >= 0
    (scalar or array) in the units of ``modulus``.
    """
    g = require_positive("rms_slope", rms_slope)
    e = require_positive("modulus", modulus)
    p = np.asarray(pressure, dtype=np.float64)
    if not np.isfinite(p).all() or (p < 0).any():
        raise InputError(f"pressure must be finite and >= 0, got {pressure!r}")
    a = erf(math.sqrt(2.0) * p / (e * g))
    return float(a) if a.ndim == 0 else a


@lru_cache(maxsize=4)
def _k_table(energy_factor: float) -> tuple[np.ndarray, np.ndarray]:
    """J(t0) tabulated on ln t0 in [ln 1e-9, ln 7] (see module doc)."""
    s = np.linspace(math.log(1e-9), math.log(7.0), 40001)
    t = np.exp(s)
    integrand = erf(t) ** 2 * np.exp(-t * t)  # dt/t = ds
    cum = cumulative_simpson(integrand[::-1], x=-s[::-1], initial=0.0)[::-1]
    j = energy_factor * 0.5 * exp1(t * t) + 3.0 * (1.0 - energy_factor) * cum
    for a in (s, j):  # cached and shared: read-only
        a.setflags(write=False)
    return s, j


def _j(t0: np.ndarray, energy_factor: float) -> np.ndarray:
    """J(t0) of the module doc for an array t0 >= 0 (table interpolation in ln t0)."""
    s, j = _k_table(energy_factor)
    t0 = np.maximum(np.asarray(t0, dtype=np.float64), 1e-300)
    out = np.interp(np.log(t0), s, j)
    small = t0 < math.exp(s[0])
    if small.any():
        # below the table J = gamma_P E1(t0^2)/2 + K(0); K varies by O(t0^2) there
        k0 = j[0] - energy_factor * 0.5 * exp1(math.exp(2 * s[0]))
        # E1(x) = -gamma_E - ln x + x + O(x^2), exact to round-off below the table's start
        # (t0 < 1e-9), from ln t0: E1(t0^2) underflowed to E1(0) = inf, and the mean gap
        # came out inf below p ~ 1e-165
        e1 = -np.euler_gamma - 2.0 * np.log(t0) + t0 * t0
        out = np.where(small, energy_factor * 0.5 * e1 + k0, out)
    return np.where(t0 > math.exp(s[-1]), 0.0, out)


def persson_mean_gap(
    pressure: ArrayLike, spec: SurfaceSpec | Surface | DiscreteSpectrum, *,
    energy_factor: float = PERSSON_ENERGY_FACTOR, modulus: float = 1.0,
) -> np.ndarray | float:
    """Persson's mean gap u(p) (Yang & Persson 2008, see module doc), in units of L.

    ``pressure`` > 0 (scalar or array) in units of ``modulus`` (E*). Decreases
    monotonically with p; p ~ exp(-u/u0) at small p.
    """
    ds = _as_spectrum(spec)
    gp = _check_factor(energy_factor)
    e = require_positive("modulus", modulus)
    p = _pressures(pressure, e)
    coef = ds.q * ds.power * ds.w / (2.0 * math.sqrt(math.pi))
    flat = p.ravel()
    u = np.empty(flat.size)
    for i, pi in enumerate(flat):
        u[i] = float(_wsum(coef, _j(ds.w * pi / e, gp)))
    u = u.reshape(p.shape)
    return float(u) if u.ndim == 0 else u


def persson_u0(
    spec: SurfaceSpec | Surface | DiscreteSpectrum, *,
    energy_factor: float = PERSSON_ENERGY_FACTOR,
) -> float:
    """Decay length u0 of p ~ exp(-u/u0) at small p (units of L)."""
    ds = _as_spectrum(spec)
    gp = _check_factor(energy_factor)
    return gp / (2.0 * math.sqrt(math.pi)) * float(_wsum(ds.q * ds.power, ds.w))


def persson_elastic_energy(
    pressure: ArrayLike, spec: SurfaceSpec | Surface | DiscreteSpectrum, *,
    energy_factor: float = PERSSON_ENERGY_FACTOR, modulus: float = 1.0,
) -> np.ndarray | float:
    """Stored elastic energy per unit area U_el(p) (module doc), units E* L.

    Tends to the full-contact energy (E*/4) sum_q |q| |h_q|^2 as p -> infinity.
    """
    ds = _as_spectrum(spec)
    gp = _check_factor(energy_factor)
    e = require_positive("modulus", modulus)
    p = np.asarray(pressure, dtype=np.float64)
    if not np.isfinite(p).all() or (p < 0).any():
        raise InputError(f"pressure must be finite and >= 0, got {pressure!r}")
    pc = erf(np.multiply.outer(p, ds.w) / e)
    u = 0.25 * e * ((ds.q * ds.power) * pc * (gp + (1.0 - gp) * pc * pc)).sum(axis=-1)
    return float(u) if np.ndim(u) == 0 else u


def predict_conductance(
    spec: SurfaceSpec | Surface, pressures: ArrayLike, *, a_c_star: float,
    kind: str = DEFAULT_MODEL,
    eta: float = 1.0, energy_factor: float = PERSSON_ENERGY_FACTOR, modulus: float = 1.0,
) -> PerssonPrediction:
    """sigma(p) from the spectrum alone: Persson a_c(p) and u(p) in the closed form Eq. (16).

    For ``kind="adhesive"`` the non-adhesive Persson a_c(p) and u(p) are used (the
    theory here has no adhesion); pass measured values to :func:`closed_form` instead
    when they are known.
    """
    ds = _as_spectrum(spec)
    p = _pressures(pressures, require_positive("modulus", modulus))
    a = np.asarray(persson_area(p, ds.rms_slope, modulus=modulus))
    u = np.asarray(persson_mean_gap(p, ds, energy_factor=energy_factor, modulus=modulus))
    sigma = np.asarray(closed_form(u, a, a_c_star=a_c_star, kind=kind, eta=eta))
    return PerssonPrediction(
        pressure=p, area_fraction=a, mean_gap=u, sigma=sigma, kind=kind, a_c_star=a_c_star
    )
