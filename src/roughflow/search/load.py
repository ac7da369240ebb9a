"""The load for a target contact area, from the contact law and the states solved so far.

Used by the threshold search, the pressure ladder, the channels scene and the benchmarks.
A search keeps its solved states (load, area, and the contact result or, with a compliance,
only what its warm starts read). The next load for a target area is

1. interpolated linearly in (load, area) between the two solves that straddle the target;
2. else extrapolated linearly from the two solves nearest to it on its side, when they
   rise monotonically;
3. else extrapolated along the contact law (:class:`roughflow.contact.law.ContactLaw`) from
   the nearest solve, or taken from the law alone before any solve;

and kept inside the allowed bounds. A load equal to one already solved is replaced by the
middle of the bounds, so that a search never repeats a solve.

Warm starts: the solve at a new load starts from the solved states around it, interpolated
linearly in the load between the nearest solves on both sides, or extrapolated from the two
nearest by at most their spacing (4 spacings with ``compliance``). Interpolating instead of
taking the lower state saves about a third of the GFMD steps of a solve inside a threshold
bracket (15 -> 10 steps to tol 1e-4 on 256^2 surfaces). With ``compliance`` (the threshold
search, ladder and channels scenes) the interpolated quantity is q = gap - c * pressure,
> 0 on open cells and < 0 on contact cells: a cell that closes between the two states closes
where q crosses zero instead of staying open and unbalanced up to the upper state. Starting
residuals are 3-4x lower, and a threshold pair needs about 15 % fewer iterations
(c = :data:`WARM_START_CELLS` single-cell compliances).

The elastic threshold search keeps each solved state as q in float32
(:class:`CompactState`) and passes reused arrays as ``out=``: :func:`warm_start` accepts
either kind of state.

Units: loads in E* gbar (bearing model: the contact area itself).
"""

from __future__ import annotations

import dataclasses
import logging
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from roughflow._jit import njit
from roughflow.contact import ContactResult, cell_compliance
from roughflow.contact.law import ContactLaw
from roughflow.defaults import DEFAULT_MODEL
from roughflow.errors import InputError, require_positive
from roughflow.surface import Surface

log = logging.getLogger(__name__)

#: Contact solves allowed for one target of :func:`solve_for_area`.
MAX_SOLVES_PER_TARGET = 30
#: Warm starts interpolate q = gap - c * pressure with c this many single-cell compliances:
#: 10 seeds of threshold pairs at 512^2 (tol 2e-3) needed 71.3 iterations per pair with the
#: gap interpolated alone, 60.3 / 60.4 / 62.2 / 63.3 with 1 / 2 / 4 / 8 cells.
WARM_START_CELLS = 2.0
#: Largest extrapolation of a warm start beyond the two nearest solves, in units of their
#: load spacing: 1 for gap and pressure, 4 for q (the same pairs: 60.4 -> 58.2 iterations;
#: unbounded 57.4, but a far extrapolation from two close solves amplifies their noise).
EXTRAPOLATE_SPACINGS = {False: 1.0, True: 4.0}


def warm_start_compliance(surface: Surface, model: str = DEFAULT_MODEL) -> float | None:
    """The ``compliance`` of :func:`warm_start` for ``surface``: :data:`WARM_START_CELLS`
    single-cell compliances (units L / E*); None for the adhesive model, whose states stay
    whole: q = gap - c max(p, 0) has no room for a contact cell in tension, and warm starts
    without it cost 1845-16680 iterations where 35-60 do (a ladder), or 1575 where 50 do (a
    threshold search), and at zero load flew off to the detached state."""
    if model == "adhesive":
        return None
    return WARM_START_CELLS * cell_compliance(surface.shape, surface.lx, surface.ly)


class SolvedPoint(Protocol):
    """A solved state of a load search."""

    load: float
    area: float
    state: ContactResult | None


@dataclass(frozen=True)
class Point:
    """A solved state: ``load`` gave contact area ``area``; ``state`` is the contact result."""

    load: float
    area: float
    state: ContactResult | None = None


def load_for_area(target: float, points: Sequence[SolvedPoint], law: ContactLaw, *,
                  bounds: tuple[float, float]) -> float:
    """Load expected to give contact area ``target`` (module docstring, steps 1-3)."""
    lo_b, hi_b = bounds
    if not points:
        return min(max(law.control(target), lo_b), hi_b)
    srt = sorted(points, key=lambda q: q.load)
    load = None
    for q0, q1 in zip(srt[:-1], srt[1:], strict=True):
        if (q0.area - target) * (q1.area - target) <= 0 and q0.area != q1.area:
            load = q0.load + (target - q0.area) / (q1.area - q0.area) * (q1.load - q0.load)
            break
    if load is None:
        side = [q for q in srt if (q.area < target) == (srt[0].area < target)]
        up = target > side[0].area  # ties in area: prefer the solves farthest towards target
        near = sorted(side, key=lambda q: (abs(q.area - target), -q.load if up else q.load))[:2]
        if len(near) == 2 and near[0].area != near[1].area and \
                (near[0].load - near[1].load) * (near[0].area - near[1].area) > 0:
            q0, q1 = near
            load = q0.load + (target - q0.area) / (q1.area - q0.area) * (q1.load - q0.load)
        else:
            load = law.extrapolate(target, near[0].load, near[0].area)
    load = min(max(load, lo_b), hi_b)
    if any(abs(load - q.load) <= 1e-12 * max(abs(load), 1e-300) for q in srt):
        load = 0.5 * (lo_b + hi_b)
    return load


@dataclass(frozen=True, eq=False)
class CompactState:
    """What a threshold search, and a :class:`LoadSearch` with a compliance, keeps of a solved
    state: q = gap - c pressure (the warm starts' variable, c = ``compliance``) in float32,
    4 bytes a cell instead of the 17 of a :class:`ContactResult`, plus the solve's
    diagnostics. gap = max(q, 0) and pressure =
    max(-q, 0) / c are rebuilt from it (exactly where the state is in contact or open: the
    solver's gap is 0 in contact and its pressure 0 off it), and q orders the cells as the
    prediction key ``percolation.openness`` does. Its float32 rounding (6e-8 relative) moves
    a warm start by far less than a contact tolerance.

    A state capped at a hardness H (``contact.solve(..., hardness=)``) keeps q = gap - c
    pressure - plastic depth: its plastic cells (pressure H, gap 0) get q below -c H by their
    depth, so they come back at a pressure above H (a capped cg solve clips its start to H
    and holds the cells there as plastic) and order below every elastic contact cell, the
    deepest last: in the rigid-plastic limit the order of the heights, the bearing model's.
    ``hardness``: that H (None for an elastic state): a start rebuilt from q gets back the
    plastic depth c (pressure - H) where its pressure exceeds H (:func:`_from_q`), which a
    gfmd warm start needs (its elastic surface lies below the heights there)."""

    q: np.ndarray
    compliance: float
    iterations: int
    residual: float
    hardness: float | None = None


@njit(cache=True, nogil=True)
def _q_kernel(gap, pressure, compliance, out):  # pragma: no cover - compiled
    """out = gap - compliance max(pressure, 0), rounded to ``out``'s dtype (one pass)."""
    for i in range(gap.size):
        out[i] = gap[i] - compliance * max(pressure[i], 0.0)


@njit(cache=True, nogil=True)
def _start_kernel(q0, q1, w0, w1, inv_factor, p_scale, gap, pressure,
                  contact):  # pragma: no cover - compiled
    """q = w0 q0 + w1 q1 (in double); gap = max(q, 0) inv_factor, pressure = max(-q, 0)
    p_scale, contact = q < 0; returns (contact cells, sum of the gap). Branch-free: the
    sign of q changes from cell to cell at the contact edges (a branch per cell was 5x
    slower on random signs)."""
    n = 0
    total = 0.0
    for i in range(q0.size):
        q = w0 * np.float64(q0[i]) + w1 * np.float64(q1[i])
        g = max(q, 0.0) * inv_factor
        gap[i] = g
        pressure[i] = max(-q, 0.0) * p_scale
        c = q < 0.0
        contact[i] = c
        n += c
        total += g
    return n, total


def compact(result: ContactResult, compliance: float) -> CompactState:
    """The :class:`CompactState` of ``result`` (one pass, no float64 temporary but the
    signed gap of a capped state)."""
    q = np.empty(result.gap.shape, dtype=np.float32)
    _q_kernel(np.ascontiguousarray(_signed_gap(result), dtype=np.float64).ravel(),
              np.ascontiguousarray(result.contact_pressure, dtype=np.float64).ravel(),
              float(compliance), q.reshape(-1))
    return CompactState(q=q, compliance=float(compliance), iterations=int(result.iterations),
                        residual=float(result.residual), hardness=result.hardness)


def warm_start(points: Sequence[SolvedPoint], load: float, *,
               compliance: float | None = None,
               out: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
               ) -> ContactResult | None:
    """Initial contact state for a solve at ``load`` (module docstring, warm starts).

    ``compliance``: interpolate q = gap - compliance * pressure (the complementarity variable,
    > 0 open, < 0 in contact) instead of gap and pressure separately
    (:func:`warm_start_compliance`); None: gap and pressure each linearly. Needed when the
    states are :class:`CompactState`.
    ``out``: arrays of the grid's shape for the start's gap and pressure (float64, C order)
    and contact mask (bool) with ``compliance`` (a search reuses them from solve to solve;
    the start is a view of them); default new arrays.
    """
    if compliance is not None:
        compliance = require_positive("compliance", compliance)
    if not points:
        return None
    if compliance is None and any(isinstance(q.state, CompactState) for q in points):
        raise InputError("warm starts from CompactState need compliance=")
    below = [q for q in points if q.load < load]
    above = [q for q in points if q.load > load]
    if below and above:
        q0 = max(below, key=lambda q: q.load)
        q1 = min(above, key=lambda q: q.load)
    else:  # extrapolate from the two nearest solves, by at most EXTRAPOLATE_SPACINGS
        near = sorted(points, key=lambda q: abs(q.load - load))
        reach = EXTRAPOLATE_SPACINGS[compliance is not None]
        if len(near) < 2 or abs(load - near[0].load) > reach * abs(near[1].load - near[0].load):
            if compliance is None:
                return near[0].state
            return _scaled(near[0], load, compliance, out)
        q0, q1 = sorted(near[:2], key=lambda q: q.load)
    r0, r1 = q0.state, q1.state
    kinds = (ContactResult, CompactState)
    if not (isinstance(r0, kinds) and isinstance(r1, kinds)):
        return min(points, key=lambda q: abs(q.load - load)).state
    t = (load - q0.load) / (q1.load - q0.load)
    if compliance is None:
        pressure = (1.0 - t) * r0.contact_pressure + t * r1.contact_pressure
        gap = (1.0 - t) * r0.gap + t * r1.gap
        return dataclasses.replace(r0, contact_pressure=pressure, gap=gap)
    # a cell that closes between the two states closes where q crosses zero, not only at
    # the upper state (its gap interpolated linearly stays open and unbalanced till then)
    return _from_q(_q(r0, compliance), _q(r1, compliance), 1.0 - t, t, compliance, r0, 1.0,
                   load, out=out)


def _signed_gap(r: ContactResult) -> np.ndarray:
    """The gap of ``r``, minus the plastic depth of a capped state (:class:`CompactState`)."""
    return r.gap if r.plastic_depth is None else r.gap - r.plastic_depth


def _q(r: ContactResult | CompactState, compliance: float) -> np.ndarray:
    """q = gap - c max(pressure, 0) of a state (float32 for a :class:`CompactState`; minus the
    plastic depth of a capped state)."""
    if isinstance(r, CompactState):
        return r.q
    return _signed_gap(r) - compliance * np.maximum(r.contact_pressure, 0.0)


def _from_q(q0: np.ndarray, q1: np.ndarray, w0: float, w1: float, compliance: float,
            like: ContactResult | CompactState, factor: float, load: float, *,
            out: tuple[np.ndarray, np.ndarray, np.ndarray] | None) -> ContactResult:
    """The start at ``load`` from q = w0 q0 + w1 q1: gap = max(q, 0) / factor, pressure =
    factor max(-q, 0) / c (one pass; into ``out`` as in :func:`warm_start`). Where ``like``
    is capped at a hardness H, also its plastic depth c max(pressure - H, 0): q below -c H
    by the depth, after the load factor (the pressure is left above H: cg clips it)."""
    shape = q0.shape
    if out is None:
        out = (np.empty(shape), np.empty(shape), np.empty(shape, dtype=bool))
    gap, pressure, contact = out
    if not all(a.shape == shape and a.flags.c_contiguous and a.dtype == d
               for a, d in zip(out, (np.float64, np.float64, np.bool_), strict=True)):
        # the kernel writes through flat views: a copy would swallow the start
        raise InputError(f"out must be C-ordered float64, float64 and bool arrays of shape "
                         f"{shape}")
    n, total = _start_kernel(np.ascontiguousarray(q0).ravel(), np.ascontiguousarray(q1).ravel(),
                             float(w0), float(w1), 1.0 / factor, factor / compliance,
                             gap.reshape(-1), pressure.reshape(-1), contact.reshape(-1))
    cap = like.hardness
    depth = None if cap is None else compliance * np.maximum(pressure - cap, 0.0)
    if isinstance(like, ContactResult):
        # not like's depth: a stale one would move a gfmd warm start (solve subtracts it)
        return dataclasses.replace(like, contact_pressure=pressure, gap=gap,
                                   plastic_depth=depth)
    size = gap.size
    return ContactResult(gap=gap, contact_pressure=pressure, contact=contact,
                         area_fraction=n / size, mean_gap=total / size,
                         pressure=float(load), iterations=0, residual=float("nan"),
                         converged=False, model="elastic", method="gfmd", hardness=cap,
                         plastic_depth=depth)


def _scaled(q: SolvedPoint, load: float, compliance: float,
            out: tuple[np.ndarray, np.ndarray, np.ndarray] | None) -> ContactResult | None:
    """One solved state carried to ``load``: pressure times load / q.load, gap divided by it
    (a 5-10 % load step from one state: 10-11 instead of 12-13 iterations at 512^2). A
    capped state goes through its q, as a compact one does: a plastic cell's pressure then
    comes from its depth, and stays at the cap where the depth is large (scaled, the whole
    plastic set of a step down fell below the cap: 148 instead of 65 iterations, 128^2)."""
    r = q.state
    if isinstance(r, CompactState) or (isinstance(r, ContactResult)
                                       and r.plastic_depth is not None):
        f = load / q.load if q.load > 0 and load > 0 else 1.0
        key = _q(r, compliance)
        return _from_q(key, key, 1.0, 0.0, compliance, r, f, load, out=out)
    if not isinstance(r, ContactResult) or not (q.load > 0 and load > 0):
        return r
    f = load / q.load
    return dataclasses.replace(r, contact_pressure=r.contact_pressure * f, gap=r.gap * (1 / f))


def timed_solve(solve: Callable[[float, ContactResult | None], ContactResult], load: float,
                init: ContactResult | None, *, what: str) -> ContactResult:
    """``solve(load, init)`` with one progress line in the log (load, area, steps, residual,
    seconds)."""
    t0 = time.perf_counter()
    res = solve(load, init)
    log.info("%s: p = %.6g -> a_c = %.5f (%d iterations, residual %.1e, %.2f s)", what, load,
             res.area_fraction, res.iterations, res.residual, time.perf_counter() - t0)
    return res


@dataclass(frozen=True)
class AreaSolve:
    """Outcome of :meth:`LoadSearch.solve_for`: the solve whose area came closest to the
    target, that area (as measured by the search), whether it is within the tolerance, and
    the number of contact solves spent on this target."""

    result: ContactResult
    area: float
    met: bool
    solves: int


class LoadSearch:
    """Loads for a sequence of target areas on one surface (pressure ladder, channels).

    ``solve(load, init)`` runs one contact solve; ``measure(result)`` gives the area the
    targets refer to (default the cell count ``area_fraction``; the ladder uses the
    perimeter-corrected area). ``bounds`` default to the law's :attr:`ContactLaw.bounds`.
    ``compliance``: passed to :func:`warm_start` (:func:`warm_start_compliance`, which
    gives None for the adhesive model); the search then keeps its states as
    :class:`CompactState`, refused for the adhesive model.
    """

    def __init__(self, solve: Callable[[float, ContactResult | None], ContactResult],
                 law: ContactLaw, *, bounds: tuple[float, float] | None = None,
                 measure: Callable[[ContactResult], float] | None = None,
                 compliance: float | None = None):
        self._solve = solve
        self.compliance = None if compliance is None else require_positive("compliance",
                                                                             compliance)
        self.law = law
        if self.compliance is not None and law.model == "adhesive":
            raise InputError("compliance= keeps states as q = gap - c p, which loses the "
                             "adhesive contact cells' tension: give compliance=None for the "
                             "adhesive model")
        self.bounds = law.bounds if bounds is None else (float(bounds[0]), float(bounds[1]))
        if not (math.isfinite(self.bounds[0]) and math.isfinite(self.bounds[1])
                and self.bounds[0] < self.bounds[1]):
            raise InputError(f"load bounds must be finite and increasing, got {bounds!r}")
        self.measure = measure or (lambda r: float(r.area_fraction))
        self.points: list[Point] = []
        self._latest: ContactResult | None = None  # the last solve whole (out-of-reach targets)

    def solve_for(self, target: float, tol: float, *,
                  max_solves: int = MAX_SOLVES_PER_TARGET) -> AreaSolve:
        """Solve until the measured area is within ``tol`` of ``target``, at most
        ``max_solves`` times, and stop early when a solve at a bound shows the target out of
        reach; returns the closest solve of this surface (``met`` False if none was within
        ``tol``: the state is a converged contact at another area, not a failure)."""
        tol = require_positive("tol", tol)
        if not 0.0 < target < 1.0:
            raise InputError(f"target contact area must lie in (0, 1), got {target!r}")
        best: tuple[float, ContactResult, float] | None = None
        n = 0
        while n < max_solves and not self._out_of_reach(target):
            n += 1
            load = load_for_area(target, self.points, self.law, bounds=self._bracket(target))
            res = timed_solve(self._solve, load, warm_start(self.points, load,
                                                              compliance=self.compliance),
                              what=f"target a_c {target:.4g}, solve {n}")
            area = self.measure(res)
            self.points.append(Point(load=float(load), area=area, state=self._kept(res)))
            self._latest = res
            miss = abs(area - target)
            if best is None or miss < best[0]:
                best = (miss, res, area)
            if miss <= tol:
                break
        if best is None:  # out of reach before any new solve: the closest earlier one
            q = min(self.points, key=lambda q: abs(q.area - target))
            res = self._latest if q is self.points[-1] else q.state
            if isinstance(res, CompactState):  # solved again from itself
                n = 1
                res = timed_solve(self._solve, q.load,
                                  warm_start([q], q.load, compliance=self.compliance),
                                  what=f"target a_c {target:.4g} out of reach, closest again")
            best = (abs(q.area - target), res, q.area)
        return AreaSolve(result=best[1], area=best[2], met=best[0] <= tol, solves=n)

    def _kept(self, res: ContactResult) -> ContactResult | CompactState:
        """What the search keeps of a solved state for its warm starts: with ``compliance``
        only q (:class:`CompactState`, 4 bytes a cell instead of 17), which is all such warm
        starts read. The paper's ladders of 12 steps solve 12 (elastic) to 16 (adhesive)
        states at 1024^2; kept whole, they were most of the 0.5-0.8 GB by which the 2048^2
        ladders overran their memory estimate (docs/workflow.md "Memory"). Only the state a
        target returns is needed whole, and it is returned."""
        return res if self.compliance is None else compact(res, self.compliance)

    def _out_of_reach(self, target: float) -> bool:
        """A solve at a bound already lies on the target's far side."""
        lo, hi = self.bounds
        return any((q.load <= lo and q.area > target) or (q.load >= hi and q.area < target)
                   for q in self.points)

    def _bracket(self, target: float) -> tuple[float, float]:
        """The bounds narrowed to the solves that straddle ``target``."""
        lo, hi = self.bounds
        for q in self.points:
            if q.area < target:
                lo = max(lo, q.load)
            elif q.area > target:
                hi = min(hi, q.load)
        if hi <= lo:  # the area is not monotonic in the load here: use the whole bounds
            return self.bounds
        return lo, hi
