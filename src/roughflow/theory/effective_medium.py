"""Bruggeman effective-medium conductance of a gap field (paper Sect. 2.3, Eq. 5-15).

Every self-consistent equation of the paper has the form

    1 = sum_i w_i A x / (s_i + B x) + z A / B                              (*)

for the unknown effective conductance ``x``, where ``s_i > 0`` are the local
conductivities of the open cells with (normalised) weights ``w_i`` and ``z`` is the
weight of the closed (contact, sigma = 0) cells:

* isotropic, Eq. (5): A = D, B = D - 1 with D = 1/(1 - a_c*) (Eq. 6);
* anisotropic, Persson's form, Eq. (7): A = D - 1 + g^(+-1), B = (D - 1) g^(+-1);
* anisotropic, corrected form, Eq. (9): A = 1 + (D - 1) g^(+-1), B = (D - 1) g^(+-1);
* non-contact conductivity, Eq. (13): A = 1 + Delta a~, B = Delta a~, z = 0.

The right-hand side of (*) increases monotonically in x and is concave, so the
root is unique and both ends of a bracket follow in closed form (see
:func:`Medium.root`); it is found by Newton's method on log x, kept inside that bracket
(bisection where a step would leave it), from the root of a strided sample of the cells or
the caller's guess. No fixed-point iteration is used. A :class:`Medium` (:func:`medium`)
holds one distribution for several equations and the roots already found: every
anisotropic form at gamma~ = 1 is the isotropic equation, which it then solves once.
Units: conductivities in whatever unit the input has (for a gap field,
``local_conductivity`` gives u^3/(12 eta) in L^3 / eta).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from scipy.optimize import brentq

from roughflow._jit import njit
from roughflow.errors import (
    ConvergenceError,
    InputError,
    plain_array,
    require_finite,
    require_finite_values,
    require_mask,
    require_numbers,
    require_positive,
)
from roughflow.reynolds import cubic_law

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

FORMS = ("corrected", "persson")

# Tolerances on log(sigma) of the root finders (Newton's and Brent's): the root is located
# to ~1e-13 relative.
_XTOL = 1e-13
_MAXITER = 500
#: a medium of more cells than this starts each cold root from the root of a strided sample
#: of about this many cells: off by a few per cent, so that Newton on all cells needs 3-4
#: evaluations instead of 8-12 from the bracket's middle (each a pass over every cell)
_SAMPLE = 16384
#: |H| at which a root whose bracket round-off has closed still counts as found: H sums
#: terms of order 1 (compensated), so its round-off is about 1e-16 (the Brent solver before
#: accepted bracket ends within the same 1e-14)
_ROUNDOFF_H = 1e-14
# |log(sigma_x/sigma_y) - log r| substitute for a direction that is closed (0) or
# unbounded (inf) at a trial ratio: only its sign matters to the bracketing solver.
_BIG = 1e3
# Closed-fraction weights within this (relative) distance of the threshold count as at
# the threshold: normalising weights leaves round-off of ~1e-16 in a_c.
_AT_THRESHOLD = 1e-12
# The anisotropic equations close both directions this much nearer: there the two
# directions' solutions keep too few digits to set sigma_x/sigma_y (measured at gamma = 64:
# the ratio 0.35 % off gamma^2 at 3e-9 of a_c* from the threshold, 52 % off at 1e-9; gamma
# 8 and 16 exact to 3e-10), while sigma itself is below 1e-7 of the open medium's. Scaled
# by (gamma / 64)^2 beyond gamma = 64 (or below 1/64): the distance at which the ratio is
# first 1 % off gamma^2 grows so (2e-9 (gamma / 64)^2 for gamma 64 - 3600 and 1/256, both
# forms, a_c* 0.4 and 0.5, three media), so the margin stays 50-80 times it; (gamma/64)^4
# before closed 800 times too far at gamma 256 (sigma_x 2e-5 of the open medium's set to 0).
_AT_THRESHOLD_ANISOTROPIC = 1e-7
# ... and at most this near: unbounded, the scaling closed every contact area from a large
# enough gamma on (from about 3600 with the fourth power)
_AT_THRESHOLD_ANISOTROPIC_MAX = 1e-3


@dataclass(frozen=True)
class BruggemanResult:
    """Isotropic Bruggeman solution (Eq. 5-6).

    sigma: effective conductance sigma_0 (units of the input conductivities; 0 when
        a_c >= a_c*).
    residual: |sigma_0 * RHS(sigma_0) - 1| of Eq. (5) (dimensionless).
    a_c: weight of the sigma = 0 (contact) entries.
    dimension: effective dimension D = 1/(1 - a_c*).
    """

    sigma: float
    residual: float
    a_c: float
    a_c_star: float
    dimension: float


@dataclass(frozen=True)
class AnisotropicResult:
    """Anisotropic Bruggeman solution (Eq. 7-9).

    sigma_x, sigma_y: effective conductances along x (axis 0) and y (axis 1).
    gamma_tilde: gamma sqrt(sigma_y / sigma_x), solved self-consistently (its limit 1 is
        returned when a_c >= a_c* and both conductances vanish).
    residual: largest |sigma * RHS(sigma) - 1| of the two equations at the solution.
    gamma: the Peklenik number used; form: "corrected" (Eq. 9) or "persson" (Eq. 7).
    """

    sigma_x: float
    sigma_y: float
    gamma_tilde: float
    residual: float
    gamma: float
    form: str
    a_c: float
    a_c_star: float
    dimension: float

    @property
    def ratio(self) -> float:
        """sigma_x / sigma_y (nan when both vanish)."""
        if self.sigma_y == 0:
            return math.nan if self.sigma_x == 0 else math.inf
        return self.sigma_x / self.sigma_y


@dataclass(frozen=True)
class NonContact:
    """Non-contact decomposition of the isotropic solution (Eq. 10-13).

    sigma_0: full Bruggeman conductance (Eq. 5).
    sigma_nc: characteristic non-contact conductivity, from Eq. (13) solved directly.
    sigma_nc_eq11: sigma_nc from Eq. (11) given sigma_0 (should equal ``sigma_nc``;
        their agreement checks Eq. 12, sigma_0 = sigma_nc (1 - a_c/a_c*)).
    delta_a_tilde: (a_c* - a_c)/(1 - a_c*); delta_a_prime: 1 - a_c/a_c*.
    """

    sigma_0: float
    sigma_nc: float
    sigma_nc_eq11: float
    a_c: float
    a_c_star: float
    delta_a_tilde: float
    delta_a_prime: float
    residual: float


def effective_dimension(a_c_star: float) -> float:
    """D = 1/(1 - a_c*), Eq. (6); a_c* must lie in (0, 1)."""
    a = _check_a_c_star(a_c_star)
    return 1.0 / (1.0 - a)


def local_conductivity(gap: ArrayLike, eta: float = 1.0, *,
                       contact: ArrayLike | None = None) -> np.ndarray:
    """Local Reynolds conductivity sigma = u^3/(12 eta) of a gap field (units L^3/eta).

    ``contact`` (optional boolean mask of the same shape) forces sigma = 0 there, for
    solvers that leave a tiny residual gap in contact. Gaps must be finite and >= 0.
    """
    eta = require_positive("eta", eta)
    u = _check_nonnegative("gap", gap)
    sigma = cubic_law(u, eta)
    if contact is not None:
        mask = require_mask("contact mask", contact)
        if mask.shape != u.shape:
            raise InputError(f"contact mask shape {mask.shape} differs from gap shape {u.shape}")
        sigma = np.where(mask, 0.0, sigma)
    return sigma


def bruggeman(sigma_values: ArrayLike | Medium, *, a_c_star: float,
              weights: ArrayLike | None = None) -> BruggemanResult:
    """Isotropic Bruggeman conductance sigma_0 (Eq. 5) with D = 1/(1 - a_c*) (Eq. 6).

    ``sigma_values``: local conductivities (any shape, flattened; contact cells are
    exact zeros), e.g. ``local_conductivity(gap)``, or a :class:`Medium` of them.
    ``weights``: optional non-negative weights of the same size (a histogram:
    ``sigma_values`` = bin values, ``weights`` = counts); uniform by default. Returns
    sigma_0 = 0 when the zero weight a_c reaches a_c* (no solution with sigma_0 > 0 exists
    then).
    """
    a_c_star = _check_a_c_star(a_c_star)
    m = _as_medium(sigma_values, weights)
    d = effective_dimension(a_c_star)
    x, res = m.root(d, d - 1.0)
    return BruggemanResult(sigma=x, residual=res, a_c=m.z, a_c_star=a_c_star, dimension=d)


def bruggeman_gap(gap: ArrayLike, *, a_c_star: float, contact: ArrayLike | None = None,
                  eta: float = 1.0) -> BruggemanResult:
    """:func:`bruggeman` of a gap field: sigma = gap^3/(12 eta), contact cells sigma = 0."""
    return bruggeman(local_conductivity(gap, eta, contact=contact), a_c_star=a_c_star)


def bruggeman_anisotropic(
    sigma_values: ArrayLike | Medium,
    *,
    a_c_star: float,
    gamma: float,
    form: str = "corrected",
    weights: ArrayLike | None = None,
) -> AnisotropicResult:
    """Anisotropic Bruggeman conductances sigma_x, sigma_y (Eq. 7-9).

    ``sigma_values``, ``weights``: as for :func:`bruggeman`.
    ``gamma``: Peklenik number of the medium (> 1: easy flow along x). Pass the
    height Peklenik number of the surface, or a conductivity Peklenik number (see
    :func:`roughflow.theory.conductivity_peklenik`). ``form="corrected"`` is the
    paper's Eq. (9) (a uniform medium gives sigma_x = sigma_y; sigma_x/sigma_y ->
    gamma^2 at a_c*), ``"persson"`` Persson's Eq. (7).

    Solution: with r = sigma_x/sigma_y and gamma~ = gamma/sqrt(r), each of the two
    equations is a bracketed 1D solve for given gamma~; the outer equation
    log(sigma_x(r)/sigma_y(r)) = log r is strictly monotone in log r and is solved by
    Brent's method from an explicit bracket.

    Closed at and just below a_c*: for a_c >= a_c* (1 - near) both conductances are
    returned as exactly 0 (gamma_tilde 1, residual 0), where near = 1e-7 max(1, (g/64)^2),
    g = max(gamma, 1/gamma), at most 1e-3 (from g = 6400): closer to a_c* the two
    directions keep too few digits to set sigma_x/sigma_y (the ratio 1 % off gamma^2 at
    about a fiftieth of near). The clamp is not flagged; just outside it the larger
    conductance is at most about 2 near times the mean of the open cells' (measured on
    binary and log-normal media).
    """
    a_c_star = _check_a_c_star(a_c_star)
    gamma = require_positive("gamma", gamma)
    if form not in FORMS:
        raise InputError(f"form must be one of {FORMS}, got {form!r}")
    m = _as_medium(sigma_values, weights)
    z = m.z
    d = effective_dimension(a_c_star)
    c = d - 1.0
    persson = form == "persson"

    def coeffs(g: float) -> tuple[float, float]:
        return ((c + g) if persson else (1.0 + c * g)), c * g

    # each direction's root starts from its root at the previous gamma~ (the outer solve
    # moves gamma~ a little at a time)
    last = [None, None]

    def both(g: float) -> tuple[tuple[float, float], tuple[float, float]]:
        out = []
        for k, gk in enumerate((g, 1.0 / g)):
            root = m.root(*coeffs(gk), guess=last[k])
            if 0.0 < root[0] < math.inf:
                last[k] = root[0]
            out.append(root)
        return out[0], out[1]

    def result(sx, sy, g, res) -> AnisotropicResult:
        return AnisotropicResult(
            sigma_x=sx, sigma_y=sy, gamma_tilde=g, residual=res, gamma=gamma, form=form,
            a_c=z, a_c_star=a_c_star, dimension=d,
        )

    near = min(_AT_THRESHOLD_ANISOTROPIC * max(1.0, (max(gamma, 1.0 / gamma) / 64.0) ** 2),
               _AT_THRESHOLD_ANISOTROPIC_MAX)
    if m.s.size == 0 or z >= a_c_star * (1.0 - near):
        # Both directions closed: the x and y thresholds coincide only at gamma~ = 1.
        return result(0.0, 0.0, 1.0, 0.0)

    def f(rho: float) -> float:
        (sx, _), (sy, _) = both(gamma * math.exp(-0.5 * rho))
        if sx == 0 or math.isinf(sy):
            return -_BIG
        if sy == 0 or math.isinf(sx):
            return _BIG
        return math.log(sx) - math.log(sy) - rho

    rho0 = 2.0 * math.log(gamma)  # gamma~ = 1: both equations coincide, f = -rho0 (corrected)
    f0 = f(rho0)
    iterations = 0
    if f0 == 0.0:
        rho = rho0
    else:
        # f decreases in rho: walk towards the root with doubling steps; |rho| <= 1400
        # keeps gamma~ and 1/gamma~ finite.
        step = (1.0 if f0 > 0 else -1.0) * max(abs(rho0), 1.0)
        lo, flo = rho0, f0
        for it in range(64):
            hi = min(max(lo + step, -1400.0), 1400.0)
            fhi = f(hi)
            if fhi == 0.0 or (fhi > 0) != (flo > 0):
                break
            if abs(hi) >= 1400.0:
                raise ConvergenceError(
                    f"no bracket for sigma_x/sigma_y (gamma={gamma}, form={form})",
                    residual=abs(fhi), iterations=it + 1,
                )
            lo, flo = hi, fhi
            step *= 2.0
        if fhi == 0.0:
            rho = hi
        else:
            a, b = sorted((lo, hi))
            rho, info = brentq(f, a, b, xtol=_XTOL, rtol=4 * np.finfo(float).eps,
                               maxiter=_MAXITER, full_output=True, disp=False)
            iterations = info.iterations
    g = gamma * math.exp(-0.5 * rho)
    (sx, rx), (sy, ry) = both(g)
    # residual of the self-consistency gamma~ = gamma sqrt(sigma_y/sigma_x) as well: it is
    # exp(f/2) - 1, and near a_c* f's slope grows as 1/(a_c* - a_c), so f cannot get below
    # xtol times it even where rho (the log of sigma_x/sigma_y) is exact to xtol. There the
    # error of rho, |f| over f's slope, is what measures the solution (it failed at 1e-6 of
    # a_c* from the threshold for gamma = 64, 1e-10 for gamma = 8).
    rg = abs(g / (gamma * math.sqrt(sy / sx)) - 1.0) if sx > 0 and sy > 0 else math.inf
    if math.isfinite(rg) and rg >= 1e-6:
        h = 1e-7 * max(1.0, abs(rho))
        slope = (f(rho - h) - f(rho + h)) / (2.0 * h)
        if slope > 0 and math.isfinite(slope):
            rg = abs(math.log1p(rg)) * 2.0 / slope  # |f| / |f'|: the error of rho
    res = max(rx, ry, rg)
    if not res < 1e-6:
        raise ConvergenceError(
            f"anisotropic Bruggeman did not converge (gamma={gamma}, form={form})",
            residual=res, iterations=iterations,
        )
    return result(sx, sy, g, res)


def noncontact_decomposition(sigma_values: ArrayLike | Medium, *, a_c_star: float,
                             weights: ArrayLike | None = None) -> NonContact:
    """Split the isotropic solution into contact and non-contact parts (Eq. 10-13).

    sigma_nc solves Eq. (13), 1/sigma_nc = <(1 + Da~)/(sigma + sigma_nc Da~)>_nc with
    Da~ = (a_c* - a_c)/(1 - a_c*) and <...>_nc the average over non-contact cells,
    so that sigma_0 = sigma_nc (1 - a_c/a_c*) (Eq. 12). ``sigma_nc_eq11`` is the value
    from Eq. (11) given the full sigma_0 (nan at or beyond a_c*, where sigma_0 = 0).
    ``sigma_values``, ``weights``: as for :func:`bruggeman`. The paper writes Eq. (13) as an
    integral over Pr(sigma); read with the full distribution, whose weight is 1 - a_c, it
    disagrees with Eq. (11) and (12) (3.5e-6 against 6.8e-6 on one gap); the non-contact
    average is the reading they imply, and Eq. (11) checks it (``sigma_nc_eq11``).
    """
    a_c_star = _check_a_c_star(a_c_star)
    m = _as_medium(sigma_values, weights)
    s, w, z = m.s, m.w, m.z
    if s.size == 0:
        raise InputError("every cell is in contact (all sigma = 0): no non-contact part")
    d = effective_dimension(a_c_star)
    x0, res0 = m.root(d, d - 1.0)
    if abs(z / a_c_star - 1.0) <= _AT_THRESHOLD:
        # at the threshold by the root finder's own rule (400 of 1000 cells closed summed to
        # 0.40000000000000013), which then gives sigma_0 = 0: Da~ -> 0, and Eq. (13) gives
        # the harmonic mean over the non-contact cells
        z = a_c_star
    dat = (a_c_star - z) / (1.0 - a_c_star)
    dap = 1.0 - z / a_c_star
    if dat < 0:
        raise InputError(
            f"contact fraction a_c={z:.6g} exceeds a_c*={a_c_star!r}: Eq. (13) needs "
            "a_c <= a_c*"
        )
    wn = w / w.sum()
    snc, res = Medium(s, wn, 0.0).root(1.0 + dat, dat,
                                       guess=x0 / dap if x0 > 0 and dap > 0 else None)
    if x0 > 0:
        # Eq. (11): 1/(sigma_nc + sigma_0 (D-1)) = <1/(sigma + sigma_0 (D-1))>_nc
        b = x0 * (d - 1.0)
        snc11 = 1.0 / float(_wsum(wn, 1.0 / (s + b))) - b
    else:
        snc11 = math.nan
    return NonContact(
        sigma_0=x0, sigma_nc=snc, sigma_nc_eq11=snc11, a_c=z, a_c_star=a_c_star,
        delta_a_tilde=dat, delta_a_prime=dap, residual=max(res, res0),
    )


# ----------------------------------------------------------------------------- internals



def _wsum(w: np.ndarray, v: np.ndarray) -> float:
    """sum(w * v) without BLAS: np.dot goes through (multi-threaded) OpenBLAS, which on a
    loaded shared machine was measured 200x slower than this for 3e4 entries."""
    return float(np.sum(w * v))


def _check_a_c_star(a_c_star: float) -> float:
    a = require_finite("a_c_star", a_c_star)
    if not 0.0 < a < 1.0:
        raise InputError(f"a_c_star must lie in (0, 1), got {a_c_star!r}")
    return a


def _check_nonnegative(name: str, values) -> np.ndarray:
    raw = require_numbers(name, plain_array(name, values))
    if raw.dtype.kind == "c":
        raise InputError(f"{name} must be real, got complex values")
    try:
        a = raw.astype(np.float64, copy=False)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be an array of numbers") from None
    if a.size == 0:
        raise InputError(f"{name} is empty (shape {a.shape})")
    require_finite_values(name, a)
    if (a < 0).any():
        i = int(np.argmin(a))
        raise InputError(
            f"{name} must be >= 0, got {int((a < 0).sum())} negative values "
            f"(min {a.flat[i]!r} at flat index {i})"
        )
    return a


def _distribution(sigma_values, weights) -> tuple[np.ndarray, np.ndarray, float]:
    """Positive values, their normalised weights and the normalised weight of zeros."""
    s = _check_nonnegative("sigma_values", sigma_values).ravel()
    if weights is None:
        w = np.full(s.size, 1.0 / s.size)
    else:
        w = _check_nonnegative("weights", weights).ravel()
        if w.size != s.size:
            raise InputError(f"weights has {w.size} entries but sigma_values has {s.size}")
        with np.errstate(over="ignore"):
            total = w.sum()
        if np.isinf(total):  # weights near the float maximum: the sum overflowed to inf
            w = w / w.max()
            total = w.sum()
        if not total > 0:
            raise InputError("weights sum to zero: the histogram is empty")
        w = w / total
    pos = s > 0
    z = float(w[~pos].sum())
    keep = pos & (w > 0)
    return s[keep], w[keep], z


@dataclass
class _Memo:
    """What a :class:`Medium` has worked out about itself (a cache: never compared)."""

    scaled: tuple[np.ndarray, float, float] | None = None
    sample: Medium | None = None
    roots: dict[tuple[float, float], tuple[float, float]] = field(default_factory=dict)


def _read_only(a: np.ndarray) -> np.ndarray:
    """A read-only float view of ``a`` (the caller's array stays writable): the memo holds
    only while the values do not change (:func:`medium` passes arrays of its own)."""
    v = np.asarray(a, dtype=np.float64).view()
    v.flags.writeable = False
    return v


@dataclass(frozen=True, eq=False)
class Medium:
    """A distribution of local conductivities for the self-consistent equations (*): the
    positive values ``s`` (units of the input), their normalised weights ``w`` and the
    weight ``z`` of the zeros (contact cells). It keeps the roots it has found, keyed by the
    equation's (A, B), so that equations shared by several forms are solved once (every
    anisotropic form at gamma~ = 1 is the isotropic one). Build it with :func:`medium`;
    the functions of this module take one in place of ``sigma_values``.

    Frozen, with read-only arrays, so that the memo stays true; two media are equal only
    if they are the same object (eq=False: comparing arrays cell by cell would cost a pass
    over them and say nothing the memo could use)."""

    s: np.ndarray
    w: np.ndarray
    z: float
    _memo: _Memo = field(default_factory=_Memo, init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "s", _read_only(self.s))
        object.__setattr__(self, "w", _read_only(self.w))
        object.__setattr__(self, "z", float(self.z))

    def scaled(self) -> tuple[np.ndarray, float, float]:
        """(s / max(s), max(s), sum w max(s) / s): values of order 1 for a relative
        tolerance, and the slope of (*) at x = 0 over A (inf where 1/s overflows)."""
        if self._memo.scaled is None:
            smax = float(self.s.max())
            t = self.s / smax
            with np.errstate(over="ignore", divide="ignore"):
                inverse = float(_wsum(self.w, 1.0 / t))
            self._memo.scaled = (t, smax, inverse)
        return self._memo.scaled

    def root(self, a: float, b: float, guess: float | None = None) -> tuple[float, float]:
        """(x, |H(x)|) for the root x > 0 of (*) with coefficients ``a``, ``b`` (module
        docstring; 0 where closed, inf where no finite root exists); ``guess``: a nearby
        root (e.g. of a neighbouring equation) to start from."""
        key = (float(a), float(b))
        roots = self._memo.roots
        if key not in roots:
            roots[key] = _solve_emt(self, a, b, guess)
        return roots[key]

    def sample(self) -> Medium | None:
        """A strided sample of about :data:`_SAMPLE` cells (None for smaller media): its
        roots start those of the whole medium."""
        if self.s.size <= 2 * _SAMPLE:
            return None
        if self._memo.sample is None:
            step = self.s.size // _SAMPLE
            w = self.w[::step]
            # the sample's zeros keep the medium's weight z: its positive weights are scaled
            # to 1 - z
            self._memo.sample = Medium(self.s[::step], w * ((1.0 - self.z) / w.sum()), self.z)
        return self._memo.sample


def medium(sigma_values: ArrayLike, weights: ArrayLike | None = None) -> Medium:
    """The :class:`Medium` of local conductivities ``sigma_values`` (any shape; contact
    cells exact zeros) with optional histogram ``weights`` (see :func:`bruggeman`), checked
    once for every equation solved on it."""
    return Medium(*_distribution(sigma_values, weights))


def _as_medium(sigma_values, weights) -> Medium:
    if isinstance(sigma_values, Medium):
        if weights is not None:
            raise InputError("weights must be None when sigma_values is a Medium (its "
                             "weights are already in it)")
        return sigma_values
    return medium(sigma_values, weights)


@njit(cache=True)
def _emt_sums(t, w, a, b, x):  # pragma: no cover (compiled)
    """sum_i w_i A x / (t_i + B x) (a compensated sum) and its derivative in log x,
    sum_i w_i A x t_i / (t_i + B x)^2: one pass over the cells."""
    total = 0.0
    error = 0.0
    slope = 0.0
    ax, bx = a * x, b * x
    for i in range(t.size):
        q = 1.0 / (t[i] + bx)
        v = w[i] * ax * q
        sum_ = total + v
        if abs(total) >= abs(v):
            error += (total - sum_) + v
        else:
            error += (v - sum_) + total
        total = sum_
        slope += v * t[i] * q
    return total + error, slope


def _solve_emt(m: Medium, a: float, b: float,
               guess: float | None = None) -> tuple[float, float]:
    """Root x > 0 of H(x) = sum w A x/(s + B x) + z A/B - 1 (eq. (*) in the module doc).

    Returns (x, |H(x)|); x = 0 when z A/B >= 1 - 1e-12 (closed), inf when A/B <= 1 (no finite
    root; only possible for Persson's form with D > 2). H is increasing and concave
    with H(0+) = z A/B - 1 and slope H'(0) = A sum w/s, so
    x_lo = (1 - z A/B)/(2 H'(0)) has H(x_lo) <= H(0+)/2 < 0 (concavity), and
    x_hi = 2 (1-z) A max(s) / (B (A - B)) has H(x_hi) > 0 because
    A x/(s + B x) >= (A/B)(1 - s/(B x)) for every s. Newton's method on log x stays inside
    that bracket, which each evaluation narrows (a bisection where a step would leave it),
    and starts from ``guess``, else from the root of the medium's sample, else from the
    bracket's middle.
    """
    s, w, z = m.s, m.w, m.z
    if s.size == 0:
        return 0.0, 0.0
    if b == 0.0:
        if z > 0:
            return 0.0, 0.0
        x = 1.0 / (a * float(_wsum(w, 1.0 / s)))
        return x, abs(a * x * float(_wsum(w, 1.0 / s)) - 1.0)
    h0 = z * a / b - 1.0
    if h0 >= -_AT_THRESHOLD:
        return 0.0, 0.0
    if a <= b:
        return math.inf, 0.0
    t, smax, inverse = m.scaled()
    lo = -h0 / (2.0 * a * inverse)
    if not lo > 0:  # the conductivities span more than the float range (1/t overflows)
        return _solve_emt_log(s, w, z, a, b)
    hi = max(2.0 * (1.0 - z) * a / (b * (a - b)), 2.0 * lo)
    ylo, yhi = math.log(lo), math.log(hi)
    if guess is None and (sample := m.sample()) is not None:
        try:
            guess = sample.root(a, b)[0]
        except ConvergenceError:  # only a start: the whole medium decides
            guess = None
    y = 0.5 * (ylo + yhi)
    if guess is not None and 0.0 < guess < math.inf and ylo < math.log(guess / smax) < yhi:
        y = math.log(guess / smax)
    for _ in range(_MAXITER):
        total, slope = _emt_sums(t, w, a, b, math.exp(y))
        h = total + z * a / b - 1.0
        if h == 0.0:
            return math.exp(y) * smax, 0.0
        if h < 0.0:
            ylo = y
        else:
            yhi = y
        step = -h / slope if slope > 0.0 else math.inf
        tol = _XTOL + 4.0 * np.finfo(float).eps * abs(y)
        if abs(step) <= tol:
            return math.exp(y) * smax, abs(h)
        if yhi - ylo <= tol:  # only round-off can close the bracket before Newton converges
            if abs(h) < _ROUNDOFF_H:
                return math.exp(y) * smax, abs(h)
            raise ConvergenceError("Bruggeman bracket lost to round-off", residual=abs(h),
                                   iterations=_MAXITER)
        y = y + step if ylo < y + step < yhi else 0.5 * (ylo + yhi)
    raise ConvergenceError("Bruggeman root not found", residual=abs(h), iterations=_MAXITER)


def _solve_emt_log(s: np.ndarray, w: np.ndarray, z: float, a: float,
                   b: float) -> tuple[float, float]:
    """:func:`_solve_emt` for conductivities whose ratios overflow (e.g. 1e-300 and 1e300):
    every quantity in logarithms, H(x) = sum w A / (exp(log s - log x) + B) + z A/B - 1,
    where an overflowing exp(log s - log x) is a term -> 0 and an underflowing one a term
    A/B, the exact limits; the bracket of :func:`_solve_emt` in logarithms."""
    log_s = np.log(s)
    h0 = z * a / b - 1.0
    # x_lo = -h0 / (2 A sum w/s), x_hi = 2 (1 - z) A max(s) / (B (A - B)), in logs
    log_slope = math.log(a) + float(np.logaddexp.reduce(np.log(w) - log_s))
    ylo = math.log(-h0 / 2.0) - log_slope
    yhi = max(math.log(2.0 * (1.0 - z) * a / (b * (a - b))) + float(log_s.max()),
              ylo + math.log(2.0))

    def h(y: float) -> float:
        with np.errstate(over="ignore", under="ignore"):
            return float(_wsum(w, a / (np.exp(log_s - y) + b))) + z * a / b - 1.0

    y = brentq(h, ylo, yhi, xtol=_XTOL, rtol=4 * np.finfo(float).eps, maxiter=_MAXITER)
    return math.exp(y), abs(h(y))
