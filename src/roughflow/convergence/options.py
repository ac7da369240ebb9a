"""The accuracy study's settings: frozen option sets, checked when they are made.

Only the standard library, :mod:`roughflow.defaults` and :mod:`roughflow.errors` are imported
here (the command line reads its defaults from these classes to build its parser);
:func:`study_specs` imports :mod:`roughflow.surface` when it runs.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING

from roughflow.defaults import ACCURACY_SEEDS, CONTACT_TOL
from roughflow.errors import (
    InputError,
    require_distinct,
    require_int,
    require_positive,
    require_seeds,
)

if TYPE_CHECKING:
    from roughflow.surface import SurfaceSpec

#: a_c of the sigma measurements (resolution) and of the fixed-load contact solves (tolerances)
TARGETS = (0.2, 0.35)
#: Bisection and contact tolerance of the study's threshold searches where the setting
#: varied is another: finer than the sweeps' own (2e-3 and 1e-4).
BISECT_TOL = 1e-3
THRESHOLD_CONTACT_TOL = 1e-5


def _positive_tuple(name: str, values: Iterable[float]) -> tuple[float, ...]:
    # distinct: a repeated entry would be measured again and weigh twice in the fits
    return require_distinct(name, tuple(require_positive(f"{name} entry", v) for v in values))


def _area_fractions(name: str, values: Iterable[float]) -> tuple[float, ...]:
    """Distinct contact area fractions in (0, 1) (the contact law's load for 1 or more is
    that of full contact: every such target would be the same solve)."""
    out = _positive_tuple(name, values)
    bad = [v for v in out if not v < 1.0]
    if bad:
        raise InputError(f"{name} must lie in (0, 1) (contact area fractions), got {bad}")
    return out


def check_resolutions(ppl: Iterable[int]) -> tuple[int, ...]:
    """``ppl`` (points per lambda_s) as a tuple of distinct integers >= 2 whose grids are the
    finest one sampled down (:func:`study_specs`): each must divide the largest;
    :class:`InputError` naming the value otherwise. (One resolution may be measured, and
    others added by a later run into the same file where the grids are the sweep's own; the
    report needs two, and the workflow's schema asks for two at once.)"""
    out = require_distinct("ppl", tuple(require_int("ppl entry", p, minimum=2) for p in ppl))
    finest = max(out)
    odd = [p for p in out if finest % p]
    if odd:
        raise InputError(f"ppl {', '.join(map(str, odd))} "
                         f"{'does' if len(odd) == 1 else 'do'} not divide the largest, "
                         f"{finest}: the finest grid is sampled down to the coarser ones")
    return out


def study_specs(ppl: Iterable[int], *, gamma: float = 1.0,
                l_over_lambda_r: float | None = None, seed: int = 0) -> dict[int, SurfaceSpec]:
    """The surface of each resolution of :func:`check_resolutions`' ``ppl``: the grid at p
    points per lambda_s is the finest one taken at every (max(ppl) / p)-th point. These are
    the sweep's own grids (``SurfaceSpec.from_sweep``) where those nest; where their
    FFT-friendly rounding does not (gamma 2, L/lambda_r 2: 96 and 750 points along y at 2
    and 16 points per lambda_s), the finest grid is rounded up to a multiple of every ratio
    instead (768), so that each coarser grid is whole and still has at least p points per
    lambda_s."""
    from dataclasses import replace

    from roughflow.surface import SurfaceSpec

    out = check_resolutions(ppl)
    finest = max(out)

    def sweep(p: int, multiple_of: int = 1) -> SurfaceSpec:
        return SurfaceSpec.from_sweep(gamma=gamma, l_over_lambda_r=l_over_lambda_r,
                                      points_per_lambda_s=p, seed=seed,
                                      multiple_of=multiple_of)

    specs = {p: sweep(p) for p in out}
    fine = specs[finest]
    if all((s.nx * (finest // p), s.ny * (finest // p)) == (fine.nx, fine.ny)
           for p, s in specs.items()):
        return specs
    fine = sweep(finest, math.lcm(*(finest // p for p in out)))
    return {p: replace(fine, nx=fine.nx // (finest // p), ny=fine.ny // (finest // p))
            for p in out}


@dataclass(frozen=True)
class ResolutionOptions:
    """The resolution study: one surface per seed, sampled down from ``max(ppl)``.

    ``sigma`` None: sigma at :data:`TARGETS` for gamma 1 only; without sigma the contact
    law's ``fixed_targets`` loads are solved instead (the points that fit the perimeter
    constant). ``bisect_tol``, ``threshold_contact_tol``: the threshold searches;
    ``contact_tol``: the fixed-area and fixed-load solves; ``area_tol``: how close a_c comes
    to the sigma targets.
    """

    seeds: tuple[int, ...] = ACCURACY_SEEDS
    ppl: tuple[int, ...] = (2, 4, 8, 16)
    gamma: float = 1.0
    l_over_lambda_r: float | None = None
    sigma: bool | None = None
    fixed_targets: tuple[float, ...] = (0.2, 0.35, 0.42)
    bisect_tol: float = BISECT_TOL
    threshold_contact_tol: float = THRESHOLD_CONTACT_TOL
    contact_tol: float = CONTACT_TOL
    area_tol: float = 3e-4

    def __post_init__(self) -> None:
        object.__setattr__(self, "seeds", require_seeds("seeds", self.seeds))
        object.__setattr__(self, "fixed_targets",
                           _area_fractions("fixed_targets", self.fixed_targets))
        for name in ("bisect_tol", "threshold_contact_tol", "contact_tol", "area_tol"):
            require_positive(name, getattr(self, name))
        object.__setattr__(self, "ppl", check_resolutions(self.ppl))
        # the surfaces themselves (a lambda_r longer than the cell): refused here, before
        # a run touches its files
        study_specs(self.ppl, gamma=self.gamma, l_over_lambda_r=self.l_over_lambda_r)

    @property
    def with_sigma(self) -> bool:
        """Whether sigma is measured (``sigma``, or by default for gamma 1 only)."""
        return self.gamma == 1.0 if self.sigma is None else self.sigma


@dataclass(frozen=True)
class ToleranceOptions:
    """The tolerance study at ``ppl`` points per lambda_s (the smallest of each list is the
    reference): ``contact_tols`` at the fixed loads of :data:`TARGETS` (cold solves),
    ``threshold_contact_tols`` inside a threshold search of bisection tol
    ``threshold_bisect_tol``, and ``bisect_tols`` with contact tol ``threshold_contact_tol``."""

    seeds: tuple[int, ...] = ACCURACY_SEEDS
    ppl: int = 4
    contact_tols: tuple[float, ...] = (1e-3, 1e-4, 1e-5, 1e-6, 1e-8)
    threshold_contact_tols: tuple[float, ...] = (1e-3, 1e-4, 1e-5, 1e-7)
    threshold_bisect_tol: float = BISECT_TOL
    bisect_tols: tuple[float, ...] = (0.032, 0.016, 0.008, 0.004, 0.002, 0.001, 0.0005,
                                      0.00025)
    threshold_contact_tol: float = THRESHOLD_CONTACT_TOL

    def __post_init__(self) -> None:
        object.__setattr__(self, "seeds", require_seeds("seeds", self.seeds))
        object.__setattr__(self, "ppl", require_int("tol_ppl", self.ppl, minimum=2))
        for name in ("contact_tols", "threshold_contact_tols", "bisect_tols"):
            object.__setattr__(self, name, _positive_tuple(name, getattr(self, name)))
        for name in ("threshold_bisect_tol", "threshold_contact_tol"):
            require_positive(name, getattr(self, name))


#: smallest resolution whose records fit the perimeter constant in the reports
FIT_MIN_PPL = 4
