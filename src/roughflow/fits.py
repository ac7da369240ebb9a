"""Finite-size scaling of the percolation threshold (paper Fig. 3).

    a_c*(eps) = a_c*(0) + A eps^(1/nu)

with nu = 4/3 (random-bond percolation) fixed or free; per direction (easy: stretching,
hard: contraction) with its own a_c*(0), or jointly with a shared a_c*(0) and one
amplitude per direction (the corrections have opposite signs). Fits are least squares on
the seed means at each system size; uncertainties come from a bootstrap over seeds
(resampling whole seeds with replacement keeps the correlations between sizes and
directions of one surface family).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, NamedTuple

import numpy as np
import xarray as xr
from scipy.optimize import least_squares
from scipy.stats import f as f_distribution

from roughflow.datasets.sweep import (
    INT_FILL,
    corrected_taken,
    fine_grid,
    single_setting,
    threshold_values,
)
from roughflow.datasets.units import DIMENSIONLESS, flags
from roughflow.defaults import (
    CORRECTION_MIN_POINTS,
    FIT_BOOTSTRAP,
    FIT_BOOTSTRAP_MAX,
    FIT_LACK_OF_FIT_QUANTILE,
    FIT_MIN_SEEDS,
    NU_BOUNDS,
    NU_PERCOLATION,
)
from roughflow.errors import InputError, check_nu, require_int

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

__all__ = ["UnderdeterminedFit", "scaling", "ScalingFit", "fit_scaling", "bootstrap_fit",
           "lack_of_fit_limit", "direction_names", "FITTED_DIMS", "fitted_setting",
           "corrected_text", "main_gamma", "ThresholdPoints", "threshold_points", "fit_dataset"]

log = logging.getLogger(__name__)

#: What every ``*_err`` of a fit dataset is (bootstrap_fit).
_ERR = ("(bootstrap over whole seeds, the resamples' standard deviation times "
        "sqrt(n_seeds / (n_seeds - 1)); for an interval use Student's t with n_seeds - 1 "
        "degrees of freedom)")


class UnderdeterminedFit(InputError):
    """The data cannot determine the fit's parameters (too few distinct system sizes)."""


def scaling(eps: ArrayLike, a_star: float, amplitude: float,
            nu: float = NU_PERCOLATION) -> np.ndarray:
    """a_c*(eps) = a_star + amplitude eps^(1/nu)."""
    return a_star + amplitude * np.asarray(eps, dtype=float) ** (1.0 / nu)


@dataclass(frozen=True)
class ScalingFit:
    """Result of one finite-size-scaling fit.

    ``amplitude`` maps direction name -> A; ``*_err`` are bootstrap standard errors over
    seeds (NaN without bootstrap; :func:`bootstrap_fit`); ``nu_free`` tells whether nu was
    fitted. ``n_seeds``: the seeds with data; ``chi2_dof``: chi^2 per degree of freedom of
    the seed means against the fit, with their standard errors (NaN where there is no
    degree of freedom or a point has one seed); well above 1, the model misses the data.
    """

    a_star: float
    amplitude: dict[str, float]
    nu: float
    nu_free: bool
    rms_residual: float
    n_points: int
    a_star_err: float = float("nan")
    amplitude_err: dict[str, float] = field(default_factory=dict)
    nu_err: float = float("nan")
    n_boot: int = 0
    n_seeds: int = 0
    chi2_dof: float = float("nan")

    @property
    def nu_at_bound(self) -> bool:
        """A free nu stuck at ``NU_BOUNDS``: the data do not determine it."""
        return self.nu_free and any(abs(self.nu - b) < 1e-6 * b for b in NU_BOUNDS)


def _clean(eps, a) -> tuple[np.ndarray, np.ndarray]:
    eps = np.asarray(eps, dtype=float).ravel()
    a = np.asarray(a, dtype=float).ravel()
    if eps.shape != a.shape:
        raise InputError(f"eps and a_c* need the same shape, got {eps.shape} and {a.shape}")
    ok = np.isfinite(eps) & np.isfinite(a)
    if np.any(eps[ok] <= 0):
        raise InputError(f"eps must be positive, got {eps[ok].min()!r}")
    return eps[ok], a[ok]


def fit_scaling(data: dict[str, tuple], *, nu: float | None = NU_PERCOLATION) -> ScalingFit:
    """Joint fit with a shared a_c*(0): ``data`` maps direction -> (eps, a_c*).

    One direction gives the separate fit. ``nu=None`` fits nu as well (bounded to
    ``NU_BOUNDS``). Raises :class:`UnderdeterminedFit` unless the data determine every
    parameter: each direction needs two distinct eps (its amplitude), and a free nu needs
    three distinct eps in one direction and more points than parameters (with fewer the
    fit returned its starting value nu = 4/3 with a bootstrap error of 3e-15).
    """
    names = list(data)
    if nu is not None:
        nu = check_nu(nu)
    cleaned = {k: _clean(*data[k]) for k in names}
    n = sum(len(e) for e, _ in cleaned.values())
    n_par = 1 + len(names) + (nu is None)
    distinct = {k: len(np.unique(e)) for k, (e, _) in cleaned.items()}
    if n < n_par:
        raise UnderdeterminedFit(f"{n} points cannot fix {n_par} parameters ({', '.join(names)})")
    few = {k: v for k, v in distinct.items() if v < 2}
    if few:
        raise UnderdeterminedFit(f"the amplitude of {', '.join(few)} needs two system sizes, "
                                 f"the data have {few}")
    if nu is None and (n <= n_par or max(distinct.values()) < 3):
        raise UnderdeterminedFit(
            f"a free nu needs three system sizes in one direction and more points than "
            f"parameters, got {distinct} distinct eps and {n} points for {n_par} parameters")

    eps_all = np.concatenate([e for e, _ in cleaned.values()])
    all_a = np.concatenate([a for _, a in cleaned.values()])
    # row -> direction: the amplitude columns of the design matrix
    owner = np.repeat(np.arange(len(names)), [len(e) for e, _ in cleaned.values()])
    one_hot = owner[:, None] == np.arange(len(names))[None, :]

    def design(v: float) -> np.ndarray:
        """Columns d(model)/d(a_star, amplitudes): the model is linear in them."""
        return np.column_stack([np.ones(n), one_hot * (eps_all ** (1.0 / v))[:, None]])

    if nu is not None:
        # linear least squares, solved exactly (the iterative solver stopped at its own
        # tolerance, 1e-8 in the cost, and took 4 ms a fit: most of a bootstrap's time)
        coef = np.linalg.lstsq(design(nu), all_a, rcond=None)[0]
        a0, amps, v = coef[0], coef[1:], nu
    else:
        def resid(x):
            return design(x[-1]) @ x[:-1] - all_a

        def jac(x):
            v = x[-1]
            power = eps_all ** (1.0 / v)
            amp = x[1:-1][owner]
            # d/dnu of A eps^(1/nu) = -A eps^(1/nu) ln(eps) / nu^2
            return np.column_stack([design(v), -amp * power * np.log(eps_all) / v**2])

        x0 = [float(np.mean(all_a))] + [0.0] * len(names) + [NU_PERCOLATION]
        lo = [-np.inf] * (1 + len(names)) + [NU_BOUNDS[0]]
        hi = [np.inf] * (1 + len(names)) + [NU_BOUNDS[1]]
        x = least_squares(resid, x0, jac=jac, bounds=(lo, hi)).x
        a0, amps, v = x[0], x[1:-1], x[-1]
    r = design(v) @ np.concatenate([[a0], amps]) - all_a
    amplitude = dict(zip(names, map(float, amps), strict=True))
    return ScalingFit(a_star=float(a0), amplitude=amplitude, nu=float(v), nu_free=nu is None,
                      rms_residual=float(np.sqrt(np.mean(r**2))), n_points=n)


def _check_n_boot(n_boot: int) -> int:
    return require_int("bootstrap resamples", n_boot, minimum=0, maximum=FIT_BOOTSTRAP_MAX)


def bootstrap_fit(eps: dict[str, np.ndarray], a_seed: dict[str, np.ndarray], *,
                  nu: float | None = NU_PERCOLATION, n_boot: int = FIT_BOOTSTRAP,
                  rng: np.random.Generator | int | None = 0) -> ScalingFit:
    """Fit the seed means, with bootstrap errors over seeds.

    ``eps[d]`` has shape (n_points,), ``a_seed[d]`` shape (n_seeds, n_points) with NaN
    where a seed was not run; the same seed index is resampled in every direction. The
    errors are the resamples' standard deviations scaled by sqrt(n / (n - 1)) for the n
    seeds with data (the bootstrap's own bias: without it, 2-4 seeds covered the truth at
    1 error in 38-60 % of synthetic studies instead of 47-65 %); an interval needs Student's
    t with n - 1 degrees of freedom, and below :data:`FIT_MIN_SEEDS` seeds a warning says
    so. They stay NaN where a point has one seed (nothing to resample there). ``chi2_dof``
    is also given (:class:`ScalingFit`).
    """
    n_boot = _check_n_boot(n_boot)
    rng = np.random.default_rng(rng)
    names = list(eps)
    n_seeds = {np.asarray(a_seed[d]).shape[0] for d in names}
    if len(n_seeds) != 1:
        raise InputError(f"every direction needs the same seeds, got {n_seeds}")
    ns = n_seeds.pop()
    values = {d: np.asarray(a_seed[d], float) for d in names}
    counts = {d: np.isfinite(values[d]).sum(0) for d in names}
    # seeds without data (a series run on fewer seeds) are not drawn: they only lost
    # resamples and widened the error (6 % with 5 of 10 seeds empty)
    data_seeds = np.flatnonzero(np.any([np.isfinite(values[d]).any(1) for d in names], axis=0))
    with_data = int(data_seeds.size)

    def means(idx):
        with np.errstate(invalid="ignore"), _quiet():
            return {d: (eps[d], np.nanmean(values[d][idx], axis=0)) for d in names}

    best = fit_scaling(means(np.arange(ns)), nu=nu)
    best = replace(best, n_seeds=with_data, chi2_dof=_chi2_dof(best, eps, values, counts))
    if n_boot <= 0:
        return best
    if with_data < 2:
        log.warning("no bootstrap error: the dataset has one seed (nothing to resample)")
        return best
    # a point with one seed has no scatter to resample: every resample that keeps it is the
    # same fit, and the error would be 0 (or blind to that point's spread); none is given.
    # A point with none is not fitted at all.
    single = sorted({f"{d} at eps {e:g}" for d in names
                     for e, n in zip(eps[d], counts[d], strict=True) if n == 1})
    if single:
        log.warning("no bootstrap error: %s %s only one seed", ", ".join(single),
                    "has" if len(single) == 1 else "have")
        return best
    samples = []
    for _ in range(n_boot):
        idx = rng.choice(data_seeds, size=with_data)
        try:
            f = fit_scaling(means(idx), nu=nu)
        except InputError:
            continue
        samples.append([f.a_star, *[f.amplitude[d] for d in names], f.nu])
    s = np.asarray(samples)
    if len(s) < 2:
        log.warning("no bootstrap error: %d of %d resamples could be fitted (the others "
                    "lacked the sizes the fit needs)", len(s), n_boot)
        return best
    if with_data < FIT_MIN_SEEDS:
        log.warning("fit errors from %d seeds are rough: for an interval use Student's t "
                    "with %d degrees of freedom (at 1 error the truth lies inside in about "
                    "half of such studies)", with_data, with_data - 1)
    err = s.std(axis=0, ddof=1) * np.sqrt(with_data / (with_data - 1))
    return replace(
        best, a_star_err=float(err[0]),
        amplitude_err={d: float(e) for d, e in zip(names, err[1:-1], strict=True)},
        nu_err=float(err[-1]) if nu is None else float("nan"), n_boot=len(s),
    )


def lack_of_fit_limit(fit: ScalingFit, n_directions: int) -> float:
    """The chi2_dof above which ``fit`` misses its data (:data:`FIT_LACK_OF_FIT_QUANTILE`
    of F(dof, n_seeds - 1)); inf where there is no degree of freedom."""
    dof = fit.n_points - (1 + n_directions + fit.nu_free)
    if dof < 1 or fit.n_seeds < 2:
        return float("inf")
    return float(f_distribution.ppf(FIT_LACK_OF_FIT_QUANTILE, dof, fit.n_seeds - 1))


def _chi2_dof(fit: ScalingFit, eps: dict, values: dict, counts: dict) -> float:
    """chi^2 per degree of freedom of the seed means against ``fit``, each residual over its
    mean's standard error; NaN where a fitted point has fewer than two seeds, or no degree
    of freedom is left. The seed means of one size are independent of each other's noise
    only in part (one seed is one surface at every size), so this is a diagnostic, not a
    test at its nominal level."""
    n_points = sum(int((counts[d] > 0).sum()) for d in values)
    if n_points - (1 + len(values) + fit.nu_free) <= 0:
        return float("nan")
    chi2 = 0.0
    n = 0
    for d, a in values.items():
        fitted = counts[d] > 0
        if np.any(counts[d][fitted] < 2):
            return float("nan")
        with np.errstate(invalid="ignore"), _quiet():
            mean = np.nanmean(a[:, fitted], axis=0)
            sem = np.nanstd(a[:, fitted], axis=0, ddof=1) / np.sqrt(counts[d][fitted])
        model = scaling(np.asarray(eps[d], float)[fitted], fit.a_star, fit.amplitude[d], fit.nu)
        miss = np.abs(mean - model)
        # seeds that agree exactly (sem 0): a miss beyond the fit's own precision (about 1e-8
        # for exact data) is infinitely many errors
        exact = sem <= 1e-12
        if np.any(exact & (miss > 1e-6)):
            return float("inf")
        chi2 += float(np.sum((miss[~exact] / sem[~exact]) ** 2))
        n += int(fitted.sum())
    dof = n - (1 + len(values) + fit.nu_free)
    return chi2 / dof if dof > 0 else float("nan")


class _quiet:
    """Silence numpy's 'mean of empty slice' warnings inside the bootstrap."""

    def __enter__(self):
        import warnings

        self._w = warnings.catch_warnings()
        self._w.__enter__()
        warnings.simplefilter("ignore", category=RuntimeWarning)

    def __exit__(self, *exc):
        return self._w.__exit__(*exc)


def direction_names(gamma: float) -> dict[str, str]:
    """axis label -> easy/hard (gamma > 1 stretches along x: x is the easy direction)."""
    return {"x": "easy", "y": "hard"} if gamma >= 1 else {"x": "hard", "y": "easy"}


#: What a fit file records of the series it fitted (``fitted_<dim>`` attributes), so that a
#: figure can refuse a fit of another series.
FITTED_DIMS = ("model", "hurst", "eps_f")


def fitted_setting(a: xr.DataArray) -> dict:
    """``fitted_model``, ``fitted_hurst``, ``fitted_eps_f``: the series' single values."""
    return {f"fitted_{d}": (str(a[d].item()) if d == "model" else float(a[d]))
            for d in FITTED_DIMS if d in a.coords and a[d].ndim == 0}


def corrected_text(ds: xr.Dataset) -> str:
    """Which a_c* :func:`~roughflow.datasets.sweep.threshold_values` gave the fit, from the
    rule it applies (:func:`~roughflow.datasets.sweep.corrected_taken`): the finite values
    it took from ``a_c_star_corrected`` and those it kept raw, below
    :data:`CORRECTION_MIN_POINTS` points per lambda_s or without a corrected value."""
    used = np.isfinite(np.asarray(threshold_values(ds), dtype=float))
    take = corrected_taken(ds)
    if take is None:
        return "raw"
    take = np.asarray(take, dtype=bool)
    fine = np.asarray(fine_grid(ds), dtype=bool)
    corrected, coarse, missing = used & take, used & ~fine, used & fine & ~take
    if not corrected.any():
        return "raw"
    if not (coarse.any() or missing.any()):
        return "perimeter-corrected"
    text = f"perimeter-corrected on grids of >= {CORRECTION_MIN_POINTS:g} points per lambda_s"
    if coarse.any():
        text += ", raw on coarser ones"
    if missing.any():
        text += ", raw where a_c_star_corrected is missing"
    return text


def main_gamma(a: xr.DataArray) -> float | None:
    """The anisotropic gamma (!= 1) of ``a`` (a_c* over gamma, eps_t, ...) with data at the
    most system sizes, the smallest such gamma on a tie; None without one. The anisotropic
    fits take this series alone, and Fig. 3 draws it as circles."""
    best, most = None, 0
    for g in sorted(a["gamma"].values):
        if np.isclose(g, 1.0):
            continue
        values = np.asarray(a.sel(gamma=g).transpose("eps_t", ...).values, dtype=float)
        sizes = int(np.isfinite(values.reshape(values.shape[0], -1)).any(1).sum())
        if sizes > most:
            best, most = float(g), sizes
    return best


class ThresholdPoints(NamedTuple):
    """The points of one finite-size-scaling fit, keyed by direction: ``eps`` the eps_t
    with data, ``a_seed`` the per-seed a_c* there (seed along axis 0, eps_t along axis 1)."""

    eps: dict[str, np.ndarray]
    a_seed: dict[str, np.ndarray]


def threshold_points(ds: xr.Dataset, group: str) -> ThresholdPoints:
    """(eps, a_seed) per direction from a threshold study dataset.

    ``group`` "anisotropic" takes the gamma of :func:`main_gamma` (its easy and hard
    directions), "isotropic" gamma == 1 (its x and y thresholds are one direction, "both").
    Points are the eps_t with data. Other gamma are not fitted: one law with one amplitude
    per direction does not hold across gamma (pooled with gamma = 2 in the default run,
    gamma = 1.5, 3, 4 at one size gave chi2_dof 7-14 against 0.5-2.3 for gamma = 2 alone).
    """

    a = single_setting(threshold_values(ds))
    eps, aseed = {}, {}
    main = main_gamma(a)
    for g in a["gamma"].values:
        iso = bool(np.isclose(g, 1.0))
        if (group == "isotropic") != iso or (not iso and g != main):
            continue
        sub = a.sel(gamma=g)
        names = {"x": "both", "y": "both"} if iso else direction_names(float(g))
        for e in sub["eps_t"].values:
            col = sub.sel(eps_t=e).transpose("seed", "axis").values
            for k, ax in enumerate(("x", "y")):
                if not np.isfinite(col[:, k]).any():  # no seed of this axis ran here
                    continue
                d = names[ax]
                eps.setdefault(d, []).append(float(e))
                aseed.setdefault(d, []).append(col[:, k])
    if not eps:
        raise InputError(f"no {group} thresholds in the dataset")
    return ThresholdPoints({d: np.asarray(v) for d, v in eps.items()},
                           {d: np.stack(v, axis=1) for d, v in aseed.items()})


def _main_gamma_attr(ds: xr.Dataset) -> float:
    """The anisotropic fits' gamma (:func:`main_gamma`; NaN without one)."""
    g = main_gamma(single_setting(threshold_values(ds)))
    return float("nan") if g is None else g


def fit_dataset(ds: xr.Dataset, *, n_boot: int = FIT_BOOTSTRAP, nu: float = NU_PERCOLATION,
                seed: int = 0) -> xr.Dataset:
    """Every fit of Fig. 3 as a dataset over (group, fit, nu_mode).

    fit: "easy", "hard" (separate a_c*(0) per direction) and "joint" (shared); for the
    isotropic group only "joint" (x and y pooled). nu_mode: "fixed" (nu given) or "free".
    A fit the data cannot determine (:class:`UnderdeterminedFit`) is NaN with
    ``underdetermined`` = 1 and a warning in the log.
    """
    nu = check_nu(nu)
    n_boot = _check_n_boot(n_boot)
    seed = require_int("seed", seed, minimum=0)
    groups = [g for g in ("anisotropic", "isotropic")
              if ((ds["gamma"] != 1.0).any() if g == "anisotropic" else (ds["gamma"] == 1.0).any())]
    fits, modes = ("easy", "hard", "joint"), ("fixed", "free")
    shape = (len(groups), len(fits), len(modes))
    out = {k: np.full(shape, np.nan) for k in ("a_star", "a_star_err", "amp_easy",
                                               "amp_easy_err", "amp_hard", "amp_hard_err",
                                               "nu", "nu_err", "rms_residual",
                                               "chi2_dof")}
    # integers stay at the fill value (missing once read) where a fit does not apply (easy
    # and hard of the isotropic group, a group without data): 0 read as "determined"
    counts = ("n_points", "n_seeds", "lack_of_fit", "n_boot_used", "nu_at_bound",
              "a_star_out_of_range", "underdetermined")
    for name in counts:
        out[name] = np.full(shape, INT_FILL, dtype=np.int32)
    # a dataset of several settings is refused whole; the one setting is recorded
    setting = fitted_setting(single_setting(threshold_values(ds)))
    seeds = ds.indexes["seed"] if "seed" in ds.indexes else None
    if seeds is not None and seeds.has_duplicates:  # each would count twice in every mean
        twice = sorted({int(s) for s in seeds[seeds.duplicated()]})
        raise InputError(f"the dataset holds seed(s) {twice} more than once")
    for dim in ("gamma", "eps_t"):  # a point would be selected as two columns
        index = ds.indexes.get(dim)
        if index is not None and index.has_duplicates:
            twice = sorted({float(v) for v in index[index.duplicated()]})
            raise InputError(f"the dataset holds {dim} {twice} more than once")
    points = {}
    for group in groups:
        try:
            points[group] = threshold_points(ds, group)
        except InputError as exc:  # a group without any finite threshold stays NaN
            log.warning("%s", exc)
    if not points:
        raise InputError("the dataset has no finite threshold to fit")
    for gi, group in enumerate(groups):
        if group not in points:
            continue
        eps, aseed = points[group]
        for fi, which in enumerate(fits):
            dirs = list(eps) if which == "joint" else [which]
            if any(d not in eps for d in dirs):
                continue
            seeds_with_data = int(np.any([np.isfinite(aseed[d]).any(1) for d in dirs],
                                         axis=0).sum())
            for mi, mode in enumerate(modes):
                for name in counts:
                    out[name][gi, fi, mi] = 0
                out["n_seeds"][gi, fi, mi] = seeds_with_data  # an underdetermined fit's too
                try:
                    f = bootstrap_fit({d: eps[d] for d in dirs}, {d: aseed[d] for d in dirs},
                                      nu=nu if mode == "fixed" else None, n_boot=n_boot,
                                      rng=seed)
                except UnderdeterminedFit as exc:
                    log.warning("%s %s nu %s: not determined by the data, left NaN: %s",
                                group, which, mode, exc)
                    out["underdetermined"][gi, fi, mi] = 1
                    continue
                except InputError as exc:
                    log.warning("%s %s nu %s: %s", group, which, mode, exc)
                    continue
                out["a_star"][gi, fi, mi] = f.a_star
                out["a_star_err"][gi, fi, mi] = f.a_star_err
                out["nu"][gi, fi, mi] = f.nu
                out["nu_err"][gi, fi, mi] = f.nu_err
                out["rms_residual"][gi, fi, mi] = f.rms_residual
                out["n_points"][gi, fi, mi] = f.n_points
                out["n_seeds"][gi, fi, mi] = f.n_seeds
                out["chi2_dof"][gi, fi, mi] = f.chi2_dof
                if f.chi2_dof > lack_of_fit_limit(f, len(dirs)):
                    out["lack_of_fit"][gi, fi, mi] = 1
                    log.warning("%s %s nu %s: chi^2 per degree of freedom %.3g: the "
                                "scaling law misses the seed means by more than their "
                                "scatter, and the errors do not cover that", group, which,
                                mode, f.chi2_dof)
                out["n_boot_used"][gi, fi, mi] = f.n_boot
                out["nu_at_bound"][gi, fi, mi] = int(f.nu_at_bound)
                if not 0.0 <= f.a_star <= 1.0:  # an outlier seed or too short a lever
                    out["a_star_out_of_range"][gi, fi, mi] = 1
                    log.warning("%s %s nu %s: a_c* = %.3f lies outside [0, 1]: the data do "
                                "not support this extrapolation (an outlier seed, or sizes "
                                "too close together)", group, which, mode, f.a_star)
                for d in ("easy", "hard"):
                    key = d if d in f.amplitude else ("both" if "both" in f.amplitude else None)
                    if key is not None:
                        out[f"amp_{d}"][gi, fi, mi] = f.amplitude[key]
                        out[f"amp_{d}_err"][gi, fi, mi] = f.amplitude_err.get(key, np.nan)
                log.info("%s %s nu %s: a_c* = %.4f +- %.4f, nu = %.3f", group, which, mode,
                         f.a_star, f.a_star_err, f.nu)
    dims = ("group", "fit", "nu_mode")
    meta = {
        "a_star": "extrapolated threshold a_c*(eps -> 0)",
        "a_star_err": f"standard error of a_c*(0) {_ERR}",
        "amp_easy": "amplitude A of the easy (stretching) direction",
        "amp_easy_err": f"standard error of A (easy) {_ERR}",
        "amp_hard": "amplitude A of the hard (contraction) direction",
        "amp_hard_err": f"standard error of A (hard) {_ERR}",
        "nu": "correlation-length exponent nu", "nu_err": f"standard error of nu {_ERR}",
        "rms_residual": "rms residual of the fit to the seed means",
        "chi2_dof": "chi^2 per degree of freedom of the seed means (over their standard "
                    "errors) against the fit; NaN: no degree of freedom or a point of one seed",
        "lack_of_fit": f"1 where chi2_dof exceeds the {FIT_LACK_OF_FIT_QUANTILE:g} quantile "
                       "of the F distribution (its degrees of freedom, n_seeds - 1): the law "
                       "misses the data, and the errors, which measure the seeds' scatter "
                       "only, do not cover it",
        "n_points": "points in the fit",
        "n_seeds": "seeds with data in the fit",
        "n_boot_used": "bootstrap resamples that could be fitted (0: no error given)",
        "nu_at_bound": "1 where a free nu stopped at its bound (nu not determined by the data)",
        "a_star_out_of_range": "1 where the extrapolated a_c* lies outside [0, 1]",
        "underdetermined": "1 where the data cannot determine the fit (too few system "
                           "sizes): values NaN",
    }
    yes_no = ("lack_of_fit", "nu_at_bound", "a_star_out_of_range", "underdetermined")
    data = {k: (dims, v, {"units": DIMENSIONLESS, "long_name": meta[k],
                          **(flags() if k in yes_no else {})}) for k, v in out.items()}
    coords = {
        "group": ("group", list(groups), {"long_name": "surfaces fitted: anisotropic (the "
                                          "gamma != 1 with the most sizes, attribute "
                                          "anisotropic_gamma) or isotropic (gamma = 1)"}),
        "fit": ("fit", list(fits), {"long_name": "direction fitted: easy or hard alone, or "
                                    "joint (a shared a_c*); the isotropic group has only "
                                    "the joint fit (x and y pooled): its easy and hard "
                                    "entries, flags included, are NaN"}),
        "nu_mode": ("nu_mode", list(modes), {"long_name": "exponent nu: fixed (given) or "
                                             "free (fitted)"}),
    }
    res = xr.Dataset(data, coords=coords,
                     attrs={"title": "finite-size-scaling fits a_c*(eps) = a_c* + A eps^(1/nu)",
                            "nu_fixed": nu, "n_boot": n_boot, "bootstrap_seed": seed,
                            **setting, "a_c_star_used": corrected_text(ds),
                            "anisotropic_gamma": _main_gamma_attr(ds),
                            "eps": "eps_t = max(sqrt(gamma), 1/sqrt(gamma)) lambda_r / L"})
    if not np.isfinite(out["a_star"]).any():
        log.warning("no fit could be determined: every fit needs at least two system sizes "
                    "per direction (and three for a free nu)")
    for name in counts:
        res[name].encoding = {"dtype": "int32", "_FillValue": np.int32(INT_FILL)}
    return res
