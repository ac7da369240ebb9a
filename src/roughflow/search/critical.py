"""Critical contact area a_c* per flow direction (paper Sect. 2.2 and 3.2).

a_c*(axis) is the relative contact area at which the fluid (open cells, 4-connected) stops
spanning the cell along ``axis`` (open boundaries along it, periodic across).

- Bearing model: exact. Contact is the top fraction of heights, so the open set grows from
  the lowest cell up; one union-find pass over the cells sorted by height gives the
  critical number of open cells (:func:`roughflow.percolation.bearing_bracket`). The
  bracket is one cell (1/N) wide, wider only where heights tie.
- Elastic and adhesive models: a bracket in pressure refined with warm-started contact
  solves until the contact areas at its two ends differ by at most ``tol``; both axes come
  from one shared sequence of solves. Each loop picks the bracket to work on
  (:func:`_pick`), proposes the contact area to aim at (:func:`_propose`) and asks the
  load search (:mod:`roughflow.search.load`) for the load that should give it. With the
  default strategy ``"predict"`` the proposal comes from a first-order prediction of a_c*
  taken from a solved state: its cells ordered from the most open (largest gap) to the most
  closed (largest contact pressure) are swept with union-find
  (:func:`roughflow.percolation.predicted_threshold_by_key`, sorting only the cells near the
  state's own open fraction). f(a) = prediction - a is > 0 on every spanning state and < 0
  on every blocked one, so once both sides are known the secant root
  of f lies inside the bracket; the solve aims just past it, and plain bisection takes over
  after repeated misses; a bracket at most 2 tol wide is halved. The one-sided solves of
  the elastic model are scouts at a looser contact tolerance (:data:`SCOUT_TOL_FACTOR`),
  re-solved to the full one only if they end a closed bracket, or one too steep in a(p)
  for their areas to be trusted. The same secant root of the final bracket is the reported
  a_c* (the midpoint only brackets it). ``strategy="bisect"`` is plain bisection in a_c with
  the midpoint, the reference.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from roughflow.accuracy import PERIMETER_C, perimeter_term
from roughflow.contact import (
    ContactResult,
    check_contact_tol,
    check_hardness,
    prepare,
    require_below_hardness,
    solve,
    workspace,
)
from roughflow.contact.bearing import solve_bearing
from roughflow.contact.law import ContactLaw
from roughflow.defaults import (
    A_C_STAR_PAPER,
    AXIS_NAMES,
    CONTACT_PRESSURE_MAX,
    CONTACT_TOL_MAX,
    DEFAULT_BACKEND,
    DEFAULT_MODEL,
    MODELS,
    THRESHOLD_CONTACT_TOL,
    THRESHOLD_MAX_SOLVES,
    THRESHOLD_PRESSURE_RANGE,
    THRESHOLD_STRATEGIES,
    THRESHOLD_STRATEGY,
    THRESHOLD_TOL,
    THRESHOLD_TOL_MAX,
)
from roughflow.errors import (
    ConvergenceError,
    InputError,
    require_field,
    require_finite,
    require_positive,
)
from roughflow.gpu import check_backend
from roughflow.gpu import check_memory as gpu_check_memory
from roughflow.percolation import (
    bearing_brackets,
    check_axis,
    openness,
    percolates_along,
    predicted_threshold_by_key,
    sweep_work,
)
from roughflow.resources import check_memory
from roughflow.surface import Surface

from .load import (
    CompactState,
    compact,
    load_for_area,
    timed_solve,
    warm_start,
    warm_start_compliance,
)

if TYPE_CHECKING:
    from roughflow.contact.adhesion import Adhesion

log = logging.getLogger(__name__)

STRATEGIES = THRESHOLD_STRATEGIES

# Tuning of the target proposal, measured over 20 seeds on 256^2 and 512^2 surfaces when the
# search was built: inverse quadratic interpolation and one-sided secant steps did not save
# solves over these choices (what was tried since: docs/percolation.md, "Cost of a threshold
# pair").
#: Consecutive solves on the unintended side of the predicted root before bisecting.
MISSES_BEFORE_BISECTION = 3
#: Distance (in units of tol) by which a two-sided target is placed past the predicted root;
#: it doubles after each miss.
AIM_OFFSET = 0.3
#: A two-sided target stays at least this fraction of the bracket away from its ends.
MIN_BRACKET_STEP = 0.05
#: One-sided: overshoot the predicted distance to the threshold by this factor (the
#: first-order predictions are good to a few tens of per cent) ...
OVERSHOOT = 1.25
#: ... plus this many tolerances (doubling after each miss).
ONE_SIDED_OFFSET = 0.5
#: One-sided step of plain bisection (doubling after each miss), in contact area.
BISECT_STEP = 0.05
#: The one-sided solves of an elastic search (the first one and those that look for the far
#: side of a bracket) are scouts, solved to this many times the contact tolerance and
#: re-solved to it from their own states only if they end a closed bracket (or a too steep
#: one, below).
#: At 30 x 1e-4 the area of a state moves by <= 1.1e-4 (1024^2, 3 seeds), far below the
#: bisection tolerance, and a cold solve takes 17-19 iterations instead of 22-24 (13-15
#: instead of 18-20 from the cold start at the law's level, contact.gfmd "Cold start").
#: Iterations per pair, 10 seeds at 1024^2: 71.1 with no scouts, 61.6 with a factor 10,
#: 58.2 with 30 (7.2 -> 7.7 solves, the re-solves included; 54.2 with the level start).
SCOUT_TOL_FACTOR = 30.0
#: A scout's area is only as good as its loose tolerance: after a short warm step it can stop
#: within 0-1 iterations on its start's contact set, its area off by up to 2e-3 (256^2 -
#: 1024^2, contact tol 1e-4 - 3e-4). At the end of a bracket narrower than that error, it
#: kept the bracket from closing while the solves closed in on its load, until the search
#: ran out of solves or reported an area jump (256^2, 30 seeds, tol 5e-4: 1 search in 30
#: failed; contact tol 3e-4, tol 1e-3: 5 in 30). Such a bracket is far steeper in a(p) than
#: any real one, so a scout end is also re-solved where the bracket's slope exceeds this
#: many times that of the contact law scaled through its other end. Brackets with exact
#: ends measured 0.67-1.27 times the law's slope (285 brackets: 1024^2 tol 2e-3, 512^2 tol
#: 8e-3, 256^2 tol 2e-3); those with a stale scout end 4-300 times.
SCOUT_SLOPE_FACTOR = 2.0
#: With a hardness H, a pressure range that reaches H ends at this fraction of it instead (a
#: load of H would make every cell plastic, which ``contact.solve`` refuses). A capped
#: contact carries a mean pressure p only on an area of at least p / H, so at 0.95 H at
#: least 95 % of the cell is in contact: every threshold below that is bracketed, and the
#: solves nearer to H cost the most (contact/cg.py: up to 22 x the elastic iterations at
#: H = 1.05 x the load).
HARDNESS_RANGE_FRACTION = 0.95

# What the search's ConvergenceErrors say, named once: benchmarks/stress_threshold.py sorts
# failed searches by them.
#: Opens the error of a bracket whose ends are a contact jump apart in load.
AREA_JUMP = "contact area jumps"
#: Ends the error of a bracket of full solves that only their own area error keeps open.
STALLED_ADVICE = "tighten contact_tol or loosen tol"


class ThresholdNotBracketed(InputError):
    """The fluid spans (or never spans) over the whole allowed pressure range."""


class SolveRecord(NamedTuple):
    """One contact solve of a threshold search; ``scout``: solved to the loose scout
    tolerance (:data:`SCOUT_TOL_FACTOR` times the contact tolerance), not the full one."""

    pressure: float
    area_fraction: float
    iterations: int
    residual: float
    scout: bool = False


@dataclass(frozen=True)
class SearchOptions:
    """How a threshold search runs (the defaults are the measured choices).

    strategy: ``"predict"`` (aimed refinement) or ``"bisect"`` (plain bisection in a_c, the
        naive reference; with ``warm_start=False`` and one axis per call it is the cold
        baseline).
    pressure_range: pressures (E*) the search may try; a surface whose fluid spans at the
        top or never spans at the bottom is unbracketed. The default is for an rms gradient
        of 1 (the generated surfaces'); :func:`scaled_options` scales it to another.
    first_pressure: the first pressure tried, within ``pressure_range``; default the contact
        law's load for :data:`~roughflow.defaults.A_C_STAR_PAPER` (clamped into the range).
    contact_tol: tolerance of each contact solve (largest gap error / rms height).
    method: contact method passed to :func:`roughflow.contact.solve` (None: its default).
    max_solves: cap on the contact solves; exceeding it raises :class:`ConvergenceError`.
    warm_start: start each solve from the solved states around it.
    exact_bearing: the bearing model's exact sweep; False bisects in the area (validation).
    on_unbracketed: ``"raise"`` :class:`ThresholdNotBracketed`, or ``"nan"``: return a
        result with ``bracketed=False`` and a NaN ``a_c_star``.
    observe: maps a solved state to the state whose contact area and percolation count
        (e.g. the window of a non-periodic scan inside its solver cell,
        :meth:`roughflow.boundary.Embedding.observe`); default the solved state itself.
        Warm starts keep using the solved states. Elastic and adhesive models only.
    observed_shape: the grid of the states ``observe`` returns: ``tol`` must cover one of
        its cells, not one of the solver cell's, which can be 4 times as many (None: the
        surface's grid).
    periodic: the observed state is periodic across the flow (default), or closed by
        walls there (False: a non-periodic scan); see :func:`roughflow.percolation.percolates`.
    hardness: the elastic model only: cap H of the local contact pressure (E*, as
        ``pressure_range``), every contact solved elastic-perfectly-plastic (by gfmd, or
        by cg with ``method="cg"``; ``contact.solve(..., hardness=H)``; docs/contact.md,
        "Hardness"); a range that reaches H ends at :data:`HARDNESS_RANGE_FRACTION` x H
        (:func:`threshold`). None: purely elastic.
    """

    strategy: str = THRESHOLD_STRATEGY
    pressure_range: tuple[float, float] = THRESHOLD_PRESSURE_RANGE
    first_pressure: float | None = None
    contact_tol: float = THRESHOLD_CONTACT_TOL
    method: str | None = None
    max_solves: int = THRESHOLD_MAX_SOLVES
    warm_start: bool = True
    exact_bearing: bool = True
    on_unbracketed: str = "raise"
    observe: Callable[[ContactResult], ContactResult] | None = None
    observed_shape: tuple[int, int] | None = None
    periodic: bool = True
    hardness: float | None = None

    def __post_init__(self) -> None:
        if self.strategy not in STRATEGIES:
            raise InputError(f"strategy must be one of {STRATEGIES}, got {self.strategy!r}")
        if self.on_unbracketed not in ("raise", "nan"):
            raise InputError("on_unbracketed must be 'raise' or 'nan', got "
                             f"{self.on_unbracketed!r}")
        n = self.max_solves
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 2:
            raise InputError(f"max_solves must be an integer >= 2, got {n!r}")
        try:
            p_min, p_max = (float(v) for v in self.pressure_range)
        except (TypeError, ValueError):
            raise InputError("pressure_range must be a pair (p_min, p_max), got "
                             f"{self.pressure_range!r}") from None
        if not (math.isfinite(p_min) and math.isfinite(p_max) and p_min < p_max):
            raise InputError("pressure_range must be finite with p_min < p_max, got "
                             f"{self.pressure_range!r}")
        check_contact_tol(self.contact_tol, "contact_tol")
        if self.first_pressure is not None:
            # a first pressure outside the range would be clamped into it without a word
            # (the default one may be: it is the contact law's, whatever the range)
            first = require_finite("first_pressure", self.first_pressure)
            if not p_min <= first <= p_max:
                raise InputError(f"first_pressure must lie in pressure_range [{p_min:g}, "
                                 f"{p_max:g}], got {self.first_pressure!r}")
        if self.hardness is not None:
            self._check_hardness(p_min)

    def _check_hardness(self, p_min: float) -> None:
        """:class:`InputError` naming the value where ``hardness`` is no pressure cap the
        searched solves can take: not a positive finite number, one in pascals, or not above
        the lowest pressure of the range or the first one (a range reaching above it is
        clipped by :func:`threshold`)."""
        cap = check_hardness(self.hardness)
        require_below_hardness(p_min, cap, load_text=f"pressure_range's lowest pressure "
                               f"{p_min:g} E*", hardness_text=f"hardness={cap:g} E*")
        if self.first_pressure is not None:
            require_below_hardness(float(self.first_pressure), cap,
                                   load_text=f"first_pressure {self.first_pressure:g} E*",
                                   hardness_text=f"hardness={cap:g} E*")


@dataclass(frozen=True)
class Threshold:
    """Critical contact area for fluid flow along ``axis`` (0 = x, 1 = y).

    The fluid spans at ``a_lo`` (pressure ``p_lo``) and does not at ``a_hi`` (``p_hi``), so
    a_c* lies in [a_lo, a_hi]; both as solved to the search's ``contact_tol`` (a solve to a
    tighter tolerance can move an end by a cell or two: 20 of 480 ends on grids of 32^2 to
    48 x 24, a_c* by at most 0.3 cells); ``a_c_star`` is the estimate inside it: with the default
    strategy ``"predict"`` (periodic cells) the root of the first-order predictions of the
    two ends, linear between them (:func:`_weight`), else the midpoint. Pressures are in
    E* (NaN for the bearing model, which is parameterised by the area itself).
    ``n_solves`` counts the contact solves of the whole search (shared between the axes when
    both were asked for; scouts and their re-solves each count); ``solves`` lists them in
    order.
    ``bracketed`` is False when the allowed pressure range did not contain the threshold
    (only with ``on_unbracketed="nan"``; then ``a_c_star`` is NaN and only the side that
    was found is set).
    ``a_c_star_corrected`` removes the first-order grid bias of the elastic contact area
    (:func:`roughflow.accuracy.perimeter_corrected_area`, the perimeter taken between the two
    bracketing states with the weight of ``a_c_star``; docs/accuracy.md). For the bearing
    model the cell count of a level set is unbiased and it equals ``a_c_star``; for the
    adhesive model and a search with a hardness the constant is not calibrated: NaN.
    ``hardness``: the cap H (E*) of the search's contact solves
    (:attr:`SearchOptions.hardness`): a_c* and the pressures are those of the
    elastic-perfectly-plastic contact; None for the purely elastic (or bearing, adhesive) one.
    """

    axis: int
    a_c_star: float
    a_lo: float
    a_hi: float
    p_lo: float
    p_hi: float
    n_solves: int
    model: str
    tol: float
    bracketed: bool = True
    message: str = ""
    solves: tuple[SolveRecord, ...] = field(default=(), repr=False)
    a_c_star_corrected: float = float("nan")
    hardness: float | None = None

    @property
    def width(self) -> float:
        return self.a_hi - self.a_lo


def first_pressure(model: str = DEFAULT_MODEL) -> float:
    """First pressure of a search: the contact law's load for the paper's a_c*."""
    return ContactLaw(model).control(A_C_STAR_PAPER)


def _capped_first(first: float, hardness: float | None) -> float:
    """The first pressure ``first`` of a search, at most A_C_STAR_PAPER x ``hardness``
    where there is one: a capped contact carries a mean pressure p on an area of at least
    p / H and at least the elastic one, so its load for a_c* lies below both the elastic
    law's and a_c* H (the rigid-plastic limit); the elastic law's alone overshot a small
    H's range (every cell plastic)."""
    return first if hardness is None else min(first, A_C_STAR_PAPER * hardness)


def scaled_options(gbar: float, model: str = DEFAULT_MODEL, **fields) -> SearchOptions:
    """:class:`SearchOptions` for a surface whose pressures are in E* and whose rms gradient
    is ``gbar`` (a scan; :attr:`roughflow.surface.Surface.gbar`): the default pressure range
    and first pressure, in E* gbar, scaled by ``gbar`` (with a ``hardness``, the first
    pressure at most a_c* H, :func:`_capped_first`). ``fields``: the other options, and
    a ``pressure_range`` or ``first_pressure`` in E* that replaces the scaled default (an
    end of the range given as None keeps its scaled default). The bearing model's loads
    are areas: nothing is scaled."""
    gbar = require_positive("gbar", gbar)
    given = fields.get("pressure_range")
    if given is not None and all(p is None for p in given):
        given = None
    if model != "bearing":
        # a steep surface (gbar above 25) would reach loads that contact.solve refuses as
        # beyond any linear-elastic contact: a fluid still spanning there is unbracketed,
        # with its message
        lo, hi = (None, None) if given is None else given
        fields["pressure_range"] = (gbar * THRESHOLD_PRESSURE_RANGE[0] if lo is None else lo,
                                    min(gbar * THRESHOLD_PRESSURE_RANGE[1], CONTACT_PRESSURE_MAX)
                                    if hi is None else hi)
        if fields.get("first_pressure") is None:  # within a range given in E*
            lo, hi = (float(p) for p in fields["pressure_range"])
            first = gbar * first_pressure(model)
            if fields.get("hardness") is not None:  # SearchOptions refuses a bad one below
                first = _capped_first(first, require_positive("hardness", fields["hardness"]))
            fields["first_pressure"] = min(max(first, lo), hi)
    elif given is None:
        fields.pop("pressure_range", None)
    return SearchOptions(**fields)


def _below_hardness(opts: SearchOptions) -> tuple[SearchOptions, str]:
    """``opts`` with a pressure range that stays below its hardness H (no capped contact
    carries a load of H: every cell would be plastic, and ``contact.solve`` refuses it): a
    range that reaches H ends at :data:`HARDNESS_RANGE_FRACTION` x H instead (halfway from
    its start to H where it starts above that), its first pressure with it; and the note for
    a fluid still spanning at that top, which names the hardness as its bound ("" where the
    range was left as it was). A range starting at H or above was refused by the options."""
    cap = opts.hardness
    lo, hi = (float(p) for p in opts.pressure_range)
    if hi < cap:
        return opts, ""
    top = max(HARDNESS_RANGE_FRACTION * cap, 0.5 * (lo + cap))
    log.info("threshold search: pressures capped at %.4g, %.3g x the hardness %.4g "
             "(pressure_range %r)", top, top / cap, cap, opts.pressure_range)
    first = opts.first_pressure
    note = (f", {top / cap:.3g} x the hardness {cap:g}, which bounds the range (no capped "
            "contact carries a load of H: every cell would be plastic)")
    return dataclasses.replace(opts, pressure_range=(lo, top),
                               first_pressure=None if first is None else min(first, top)), note


def _within_wall(opts: SearchOptions, max_load: float) -> SearchOptions:
    """``opts`` with the loads the adhesive wall holds (:attr:`Adhesion.max_load`, finite on
    the harmonic wall only): the pressure range and first pressure capped there. The
    defaults are set for elastic contact (up to 4 E* gbar), which the soft wall cannot hold:
    the search failed on its own first pressure with an error about a load the caller never
    gave. A range that starts at the limit is refused before any solve, naming it."""
    lo, hi = (float(p) for p in opts.pressure_range)
    if hi <= max_load:
        return opts
    if lo >= max_load:
        raise InputError(
            f"pressure_range {opts.pressure_range!r} lies beyond the largest load the "
            f"harmonic wall holds, {max_load:.4g} (Adhesion.max_load): give a range below it, "
            "or use repulsion='hard'")
    log.info("threshold search: pressures capped at %.4g, the largest load the harmonic "
             "wall holds (pressure_range %r)", max_load, opts.pressure_range)
    first = opts.first_pressure
    return dataclasses.replace(opts, pressure_range=(lo, max_load),
                               first_pressure=None if first is None else min(first, max_load))


# -------------------------------------------------------------------------------------------
# solved states and brackets
# -------------------------------------------------------------------------------------------

@dataclass
class _Sample:
    """A solved state: ``load`` (pressure, or area for the bearing model) gave ``area``."""

    load: float
    area: float
    spans: dict[int, bool]
    state: ContactResult | CompactState | None = None
    predictor: Callable[[int], float] | None = None  # per axis, computed on first use
    perimeter: float = float("nan")
    scout: bool = False  # solved to the loose scout tolerance (SCOUT_TOL_FACTOR)
    _pred: dict[int, float] = field(default_factory=dict)

    def pred(self, ax: int) -> float:
        """Predicted a_c* along ``ax`` (first-order union-find sweep of this state); only
        the axes a search asks about are swept (a sweep costs a few solver iterations)."""
        if ax not in self._pred:
            self._pred[ax] = self.predictor(ax)
        return self._pred[ax]


def _bracket(samples: list[_Sample], ax: int) -> tuple[_Sample | None, _Sample | None]:
    """(highest-load spanning state below the blocked one, lowest-load blocked state)."""
    his = [q for q in samples if not q.spans[ax]]
    hi = min(his, key=lambda q: q.load) if his else None
    los = [q for q in samples if q.spans[ax] and (hi is None or q.load < hi.load)]
    lo = max(los, key=lambda q: q.load) if los else None
    return lo, hi


class _Work(NamedTuple):
    """An axis still to refine: its bracket width (inf while one side is unknown)."""

    width: float
    axis: int
    lo: _Sample | None
    hi: _Sample | None
    distance: float = 0.0  # one-sided: predicted distance of a_c* from the known side


def _pending(samples: list[_Sample], axes, tol: float, load_range, strategy: str,
             unbracketed: dict, top_note: str = "") -> list[_Work]:
    """Axes whose bracket is still wider than ``tol``; records unbracketable axes
    (``top_note``: what bounds the range's top, said where the fluid still spans there)."""
    todo = []
    for ax in axes:
        if ax in unbracketed:
            continue
        lo, hi = _bracket(samples, ax)
        if lo is not None and hi is not None:
            if hi.area - lo.area > tol:
                todo.append(_Work(hi.area - lo.area, ax, lo, hi))
        elif lo is None and hi is not None and hi.load <= load_range[0]:
            unbracketed[ax] = (lo, hi, f"the fluid does not span along {AXIS_NAMES[ax]} even at "
                               f"the lowest allowed pressure {load_range[0]:g} "
                               f"(a_c = {hi.area:.4g})")
        elif hi is None and lo is not None and lo.load >= load_range[1]:
            unbracketed[ax] = (lo, hi, f"the fluid still spans along {AXIS_NAMES[ax]} at the "
                               f"highest allowed pressure {load_range[1]:g}"
                               f"{top_note} (a_c = {lo.area:.4g})")
        else:
            q = lo if lo is not None else hi
            dist = abs(q.pred(ax) - q.area) if strategy == "predict" else 0.0
            todo.append(_Work(math.inf, ax, lo, hi, dist))
    return todo


def _pick(todo: list[_Work]) -> _Work:
    """An open-ended bracket first (the one predicted nearest), else the widest."""
    open_ended = [w for w in todo if w.width == math.inf]
    if open_ended:
        return min(open_ended, key=lambda w: (w.distance, w.axis))
    return max(todo, key=lambda w: (w.width, -w.axis))


def _propose(w: _Work, *, tol: float, misses: int, strategy: str) -> tuple[float, bool | None]:
    """(target contact area, expected spanning of the new state or None for bisection)."""
    lo, hi, ax = w.lo, w.hi, w.axis
    step = 2.0**misses
    if lo is not None and hi is not None:
        if strategy == "bisect" or misses >= MISSES_BEFORE_BISECTION \
                or w.width <= 2.0 * tol:
            # at most 2 tol wide: the midpoint closes the bracket on either side
            return 0.5 * (lo.area + hi.area), None
        f_lo, f_hi = lo.pred(ax) - lo.area, hi.pred(ax) - hi.area
        root = lo.area + f_lo * (hi.area - lo.area) / (f_lo - f_hi)
        off = AIM_OFFSET * tol * step
        below, above = root - off, root + off
        want = hi.area - below < above - lo.area  # True: aim for a new spanning state
        target = below if want else above
        margin = MIN_BRACKET_STEP * w.width
        return min(max(target, lo.area + margin), hi.area - margin), want
    if hi is None:  # only spanning states so far: go up
        if strategy == "bisect":
            target = lo.area + BISECT_STEP * step
        else:
            d = max(lo.pred(ax) - lo.area, 0.0)
            target = lo.area + OVERSHOOT * d + ONE_SIDED_OFFSET * tol * step
        return min(target, 0.5 * (1.0 + lo.area)), False
    if strategy == "bisect":  # only blocked states so far: go down
        target = hi.area - BISECT_STEP * step
    else:
        d = max(hi.area - hi.pred(ax), 0.0)
        target = hi.area - OVERSHOOT * d - ONE_SIDED_OFFSET * tol * step
    return max(target, 0.5 * hi.area), True


def _steepness(lo: _Sample, hi: _Sample, law: ContactLaw) -> float:
    """Slope of a(p) across a bracket over that of the contact law scaled through its full
    end (the lower one if both are scouts): 0.67-1.27 where both areas are exact
    (:data:`SCOUT_SLOPE_FACTOR`); nan where the law has none."""
    ref = lo if hi.scout else hi
    slope = (hi.area - lo.area) / (hi.load - lo.load) if hi.load > lo.load else math.inf
    return slope / law.slope(ref.load, ref.area)


def _scouts_to_resolve(samples: list[_Sample], axes, tol: float, law: ContactLaw) -> list[int]:
    """Indices of scout states that end a bracket closed to ``tol`` or one too steep for
    its area difference to be real (:data:`SCOUT_SLOPE_FACTOR`)."""
    out = set()
    for ax in axes:
        lo, hi = _bracket(samples, ax)
        if lo is None or hi is None or not (lo.scout or hi.scout):
            continue
        if hi.area - lo.area <= tol or _steepness(lo, hi, law) > SCOUT_SLOPE_FACTOR:
            out.update(i for i, q in enumerate(samples) if q.scout and (q is lo or q is hi))
    return sorted(out)


def _unresolved_hint(lo: _Sample | None, hi: _Sample | None, law: ContactLaw) -> str:
    """Why a bracket of full solves may not close: a warm start already within the contact
    tolerance returns unchanged, with its start's area, so the areas of full solves are
    only good to what that tolerance resolves."""
    steep = _steepness(lo, hi, law) if lo is not None and hi is not None else math.nan
    if not steep > SCOUT_SLOPE_FACTOR:
        return ""
    return (f"; its ends differ in area {steep:.3g} times as much as the contact law says "
            f"their loads should, so its width is the contact solves' own area error: "
            f"{STALLED_ADVICE}")


def _stalled_hint(history: list[_Sample], options: SearchOptions) -> str:
    """Where the last solves returned their warm starts unchanged (0 iterations: already
    within the contact tolerance), the areas cannot resolve the bracket: say so. Measured:
    tol 3e-4 at contact_tol 1e-2 (64^2) made 36 of its 40 solves so, most at one load."""
    last = history[-4:]
    if len(last) < 4 or any(getattr(q.state, "iterations", 1) != 0 for q in last):
        return ""
    return (f"; the last {len(last)} contact solves returned their warm starts unchanged (0 "
            f"iterations): contact_tol={options.contact_tol:g} does not resolve the area steps "
            f"the bracket needs: {STALLED_ADVICE}")


def _weight(lo: _Sample, hi: _Sample, ax: int, interpolate: bool) -> float:
    """Where a_c* lies in the bracket, as the weight of its blocked end (0 = ``lo``).

    Interpolated: the root of f(a) = prediction - a, linear between the two ends (f > 0 at
    a spanning state, < 0 at a blocked one), clipped into the bracket. Against references
    resolved to 1e-4 - 5e-4 it is 6-17x closer to a_c* than the midpoint (rms 3.4e-5 against
    3.4e-4 at 1024^2 and tol 2e-3, 1.6e-4 against 1.6e-3 at 256^2 and tol 8e-3, 10 seeds x
    2 axes; docs/accuracy.md). Otherwise, or where f does not change sign, the midpoint.
    """
    if not interpolate:
        return 0.5
    f_lo, f_hi = lo.pred(ax) - lo.area, hi.pred(ax) - hi.area
    if not f_lo - f_hi > 0.0:  # no sign change (or nan): nothing to interpolate
        return 0.5
    return min(max(f_lo / (f_lo - f_hi), 0.0), 1.0)


def _assemble(samples: list[_Sample], history: list[_Sample], axes, unbracketed: dict, *,
              model: str, tol: float, on_unbracketed: str, loads_are_pressures: bool,
              interpolate: bool) -> dict[int, Threshold]:
    """One :class:`Threshold` per axis from the solved states (``history``: every solve in
    order, scouts that were re-solved included); ``interpolate``: see :func:`_weight`."""
    n = len(history)
    records = tuple(SolveRecord(q.load, q.area, getattr(q.state, "iterations", 0),
                                float(getattr(q.state, "residual", 0.0)), q.scout)
                    for q in history)
    nan = float("nan")

    def pressure(q: _Sample | None) -> float:
        return q.load if q is not None and loads_are_pressures else nan

    out = {}
    for ax in axes:
        if ax in unbracketed:
            lo, hi, msg = unbracketed[ax]
            if on_unbracketed == "raise":
                raise ThresholdNotBracketed(msg + f" after {n} contact solves")
            out[ax] = Threshold(
                axis=ax, a_c_star=nan, a_lo=lo.area if lo else nan,
                a_hi=hi.area if hi else nan, p_lo=pressure(lo), p_hi=pressure(hi),
                n_solves=n, model=model, tol=tol, bracketed=False, message=msg,
                solves=records)
            continue
        lo, hi = _bracket(samples, ax)
        w = _weight(lo, hi, ax, interpolate)
        a = lo.area + w * (hi.area - lo.area)
        corrected = a - PERIMETER_C * (lo.perimeter + w * (hi.perimeter - lo.perimeter))
        out[ax] = Threshold(
            axis=ax, a_c_star=a, a_lo=lo.area, a_hi=hi.area,
            p_lo=pressure(lo), p_hi=pressure(hi), n_solves=n, model=model, tol=tol,
            solves=records, a_c_star_corrected=(corrected if model == "elastic" else
                                                a if model == "bearing" else nan))
    return out


def _refine(evaluate: Callable[[float, ContactResult | None, bool], _Sample], axes, *,
            tol: float, first: float, load_range: tuple[float, float], law: ContactLaw,
            options: SearchOptions, model: str, loads_are_pressures: bool,
            compliance: float | None = None, scouts: bool = False,
            start_out: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
            tie: Callable[[_Sample, _Sample], tuple[int, float] | None] | None = None,
            top_note: str = ""):
    """Refine brackets until each is at most ``tol`` wide (the loop: module docstring).
    ``tie(lo, hi)``: (count, height) where nothing but one group of cells of equal height
    lies between two states, so no load can split their bracket (the bearing model); such
    an axis is reported as unbracketed, as the exact sweep reports it. ``top_note``: see
    :func:`_pending`."""
    samples: list[_Sample] = []  # the current states (a re-solved scout replaces its own)
    history: list[_Sample] = []  # every solve in order
    misses = dict.fromkeys(axes, 0)  # consecutive solves that missed the intended side
    expected: tuple[int, bool] | None = None  # (axis, spanning the last solve aimed for)
    unbracketed: dict = {}

    def run(load: float, scout: bool = False) -> None:
        init = None
        if options.warm_start:
            init = warm_start(samples, load, compliance=compliance, out=start_out)
        samples.append(evaluate(load, init, scout))
        history.append(samples[-1])

    run(min(max(first, load_range[0]), load_range[1]), scout=scouts)
    while True:
        if expected is not None:
            ax, want = expected
            misses[ax] = misses[ax] + 1 if samples[-1].spans[ax] != want else 0
            expected = None
        # a re-solve can move a bracket onto another scout: look again until none is left
        while resolve := _scouts_to_resolve(samples, axes, tol, law):
            for i in resolve:
                own = warm_start([samples[i]], samples[i].load, compliance=compliance,
                                 out=start_out)
                samples[i] = evaluate(samples[i].load, own, False)
                history.append(samples[i])
        todo = _pending(samples, axes, tol, load_range, options.strategy, unbracketed,
                        top_note)
        if tie is not None:
            for w in todo:
                if w.lo is not None and w.hi is not None \
                        and (group := tie(w.lo, w.hi)) is not None:
                    unbracketed[w.axis] = (w.lo, w.hi, _tie_message(
                        *group, w.axis, w.lo.area, w.hi.area, tol))
            todo = [w for w in todo if w.axis not in unbracketed]
        if not todo:
            break
        if len(history) >= options.max_solves:
            widest = max(todo, key=lambda t: (t.width, t.axis))
            tried = ", ".join(f"({q.load:.4g}, {q.area:.4g})" for q in samples[-4:])
            raise ConvergenceError(
                f"threshold along {AXIS_NAMES[widest.axis]} not resolved to tol={tol:g} within "
                f"max_solves={options.max_solves} contact solves; last (load, a_c): {tried}"
                f"{_unresolved_hint(widest.lo, widest.hi, law) or _stalled_hint(history, options)}"
                "; residual = bracket width",
                residual=float(widest.width), iterations=len(samples))
        work = _pick(todo)
        lo, hi = work.lo, work.hi
        if lo is not None and hi is not None and hi.load - lo.load <= 1e-12 * hi.load:
            raise ConvergenceError(
                f"{AREA_JUMP} from {lo.area:.6g} to {hi.area:.6g} between pressures "
                f"{lo.load:.12g} and {hi.load:.12g}: threshold along "
                f"{AXIS_NAMES[work.axis]} cannot be resolved to tol={tol:g}"
                f"{_unresolved_hint(lo, hi, law)}",
                residual=float(work.width),
                iterations=len(samples))
        target, want = _propose(work, tol=tol, misses=misses[work.axis],
                                strategy=options.strategy)
        if want is not None:
            expected = (work.axis, want)
        bounds = (lo.load if lo is not None else load_range[0],
                  hi.load if hi is not None else load_range[1])
        # a one-sided solve is a scout: it rarely ends up as the end of a closed bracket
        run(load_for_area(target, samples, law, bounds=bounds),
            scout=scouts and (lo is None or hi is None))
    return _assemble(samples, history, axes, unbracketed, model=model, tol=tol,
                     on_unbracketed=options.on_unbracketed,
                     loads_are_pressures=loads_are_pressures,
                     # the predictions sweep periodically: not the estimate of a walled scan
                     interpolate=options.strategy == "predict" and options.periodic)


# -------------------------------------------------------------------------------------------
# public entry point
# -------------------------------------------------------------------------------------------

def _tie_message(tied: int, height: float, ax: int, a_lo: float, a_hi: float,
                 tol: float) -> str:
    """Why a bearing threshold has no number: a tie group spans its bracket."""
    return (f"{tied} cells share the critical height {height!r}: the threshold along "
            f"{AXIS_NAMES[ax]} is only known to lie in [{a_lo:.6g}, {a_hi:.6g}], wider than "
            f"tol={tol:g}")


def _bearing_tie(heights: np.ndarray) -> Callable[[_Sample, _Sample], tuple[int, float] | None]:
    """The ``tie`` of :func:`_refine` for bearing states of ``heights``: the cells in contact
    at ``hi`` but not at ``lo``, where they are two or more of one height."""
    flat = heights.ravel()

    def tie(lo: _Sample, hi: _Sample) -> tuple[int, float] | None:
        between = flat[(hi.state.contact & ~lo.state.contact).ravel()]
        if between.size > 1 and between.min() == between.max():
            return between.size, float(between[0])
        return None

    return tie


def _bearing_exact(heights: np.ndarray, axes, tol: float, on_unbracketed: str):
    out = {}
    for ax, b in bearing_brackets(heights, tuple(axes)).items():
        ok = b.tied == 1 or b.a_hi - b.a_lo <= tol  # one cell: exact at grid resolution
        msg = ""
        if not ok:
            msg = _tie_message(b.tied, b.height, ax, b.a_lo, b.a_hi, tol)
            if on_unbracketed == "raise":
                raise ThresholdNotBracketed(msg)
        a = 0.5 * (b.a_lo + b.a_hi) if ok else float("nan")
        out[ax] = Threshold(axis=ax, a_c_star=a, a_lo=b.a_lo, a_hi=b.a_hi, p_lo=float("nan"),
                            p_hi=float("nan"), n_solves=0, model="bearing", tol=tol,
                            bracketed=ok, message=msg, a_c_star_corrected=a)
    return out


def check_area_tol(tol: float, shape: tuple[int, int]) -> None:
    """:class:`InputError` where ``tol`` (in a_c) is below the area of one cell of the grid
    whose contact area counts: two states' areas differ by whole cells, so a bracket
    narrower than one cannot close (the search ran its solves and then stalled)."""
    cells = int(shape[0]) * int(shape[1])
    if tol * cells < 1:
        raise InputError(f"tol={tol!r} is below the area of one cell of the "
                         f"{shape[0]} x {shape[1]} grid whose area counts (1/{cells} = "
                         f"{1 / cells:.3g}): give tol >= {1 / cells:.3g}")


def check_threshold_tol(tol: float, shape: tuple[int, int], model: str,
                        options: SearchOptions | None = None) -> None:
    """:func:`check_area_tol` where the search's areas come from contact solves; the exact
    bearing sweep (``options.exact_bearing``, the default) finds a_c* to the cell and takes
    any tol."""
    opts = options or SearchOptions()
    if not (model == "bearing" and opts.exact_bearing):
        check_area_tol(tol, shape)


def threshold(
    surface: Surface,
    axis: int | None = None,
    *,
    model: str = DEFAULT_MODEL,
    tol: float = THRESHOLD_TOL,
    adhesion: Adhesion | None = None,
    options: SearchOptions | None = None,
    threads: int | None = None,
    backend: str = DEFAULT_BACKEND,
) -> Threshold | dict[int, Threshold]:
    """Critical contact area a_c* for fluid flow along ``axis`` (0 = x, 1 = y).

    ``axis=None`` returns ``{0: Threshold, 1: Threshold}`` from one shared sequence of
    contact solves. ``tol`` is the largest allowed ``a_hi - a_lo``. ``model``: ``"elastic"``
    (default), ``"adhesive"`` (needs ``adhesion=Adhesion(...)``) or ``"bearing"``.
    ``options``: :class:`SearchOptions` (strategy, pressure range, contact tolerance, ...);
    default ``scaled_options(surface.gbar, model)``: the default pressures, set in E* gbar,
    scaled to the surface's rms gradient (a_c* does not depend on it). Every contact solve
    logs one line (load, area, iterations, residual, seconds) at INFO.
    ``backend="cupy"``: the elastic gfmd solves on a CUDA GPU (``contact.solve``'s backend).
    With ``options.hardness`` H (elastic model, CPU) every solve is capped at H (by gfmd,
    with the prepared setup, the workspace and compact states as without a cap, or by
    ``options.method="cg"``), and the pressure range ends below H (:func:`_below_hardness`);
    the results carry H.
    """
    if not isinstance(surface, Surface):
        raise InputError(f"surface must be a roughflow Surface, got {type(surface).__name__}")
    axes = (0, 1) if axis is None else (check_axis(axis),)
    if model not in MODELS:
        raise InputError(f"model must be one of {MODELS}, got {model!r}")
    tol = require_positive("tol", tol)
    if tol > THRESHOLD_TOL_MAX:
        raise InputError(f"tol must be at most {THRESHOLD_TOL_MAX:g} (a contact-area "
                         f"difference), got {tol!r}")
    # a given options' pressures are taken as they are (E*); the defaults follow gbar
    gbar = surface.gbar  # 0 for a flat surface: nothing to scale (full contact at any load)
    opts = options if options is not None else (
        scaled_options(gbar, model) if gbar > 0 else SearchOptions())
    if not isinstance(opts, SearchOptions):
        raise InputError(f"options must be SearchOptions, got {type(opts).__name__}")
    if model == "elastic" and opts.pressure_range[0] <= 0:
        raise InputError("pressure_range must be positive for the elastic model, got "
                         f"{opts.pressure_range!r}")
    if model == "adhesive" and adhesion is None:
        raise InputError("model='adhesive' needs adhesion=Adhesion(surface_energy=, range=)")
    if model == "adhesive":
        opts = _within_wall(opts, adhesion.max_load)
    cap = opts.hardness
    top_note = ""
    if cap is not None:
        check_hardness(cap, model)
        if backend != "cpu":
            raise InputError(f"options.hardness={cap!r} is solved on the CPU (the GPU's "
                             f"hard-wall kernels have no pressure cap), not backend="
                             f"{backend!r}")
        opts, top_note = _below_hardness(opts)
    on_gpu = check_backend(backend, model, opts.method) == "cupy"
    if on_gpu:
        gpu_check_memory(surface.shape, "the contact solves of a threshold search on the GPU")
    # a Surface checks its heights when made, but its array can be changed in place since
    heights = require_field("surface heights", surface.heights)
    shape = heights.shape
    check_threshold_tol(tol, shape if opts.observed_shape is None else opts.observed_shape,
                        model, opts)
    # Elastic states seen whole are kept as q = gap - c pressure in float32 (CompactState, 4
    # bytes a cell instead of 17): the search then needs none of a result's arrays once it is
    # sampled, and its gfmd solves share one workspace instead of allocating (fresh memory
    # cost up to 16 % of a pair here; docs/percolation.md, "Cost of a threshold pair")
    lean = model == "elastic" and opts.observe is None
    # the adhesive search (and an observed window) keeps every state whole: its own model
    check_memory("threshold" if lean or model == "bearing" else "threshold_adhesive", shape,
                 what=f"{'a' if model == 'bearing' else 'an'} {model} threshold search")
    law = ContactLaw(model)
    compliance = warm_start_compliance(surface, model)  # None: adhesive states stay whole
    sweeps = sweep_work(heights.size) if lean else None  # predictions and spanning tests

    def sample(r: ContactResult, load: float, open_first: np.ndarray | None,
               pressure: np.ndarray | None) -> _Sample:
        seen = r if opts.observe is None else opts.observe(r)
        if r.plastic_depth is not None and not lean:
            # the prediction key ranks a plastic cell by its depth, below every elastic
            # contact cell, as a compact state's q does (CompactState)
            pressure = r.contact_pressure + r.plastic_depth / compliance
            if seen is not r:
                pressure = opts.observe(dataclasses.replace(
                    r, contact_pressure=pressure)).contact_pressure
        elif seen is not r:
            pressure = seen.contact_pressure
        area = float(seen.area_fraction)
        spans = percolates_along(~seen.contact, axes, periodic=opts.periodic, work=sweeps)
        # faces per observed cell: independent of the cell size, so a window needs no scaling
        perimeter = perimeter_term(seen.contact) if model == "elastic" else float("nan")
        state = compact(r, compliance) if lean else r
        predictor = None
        if opts.strategy == "predict" and isinstance(state, CompactState):
            key = state.q  # orders the cells as openness() does; r is not kept (a workspace's)

            def predictor(ax: int) -> float:
                # periodic union-find even with walls: the prediction only aims the solves
                return predicted_threshold_by_key(key, ax, expect=1.0 - area,
                                                  work=sweeps)
        elif opts.strategy == "predict":
            def predictor(ax: int) -> float:
                # the key is rebuilt per axis (3 ms at 1024^2), not kept: a kept 8 MB array
                # per state costs more in fresh pages (about 20 ms on these machines)
                key = open_first if open_first is not None else openness(seen.gap,
                                                                         seen.contact, pressure)
                return predicted_threshold_by_key(key, ax, expect=1.0 - area)
        return _Sample(load=float(load), area=area, spans=spans, state=state,
                       predictor=predictor, perimeter=perimeter)

    if model == "bearing":
        if opts.observe is not None or not opts.periodic:
            raise InputError("observe= and periodic=False are for the elastic and adhesive "
                             "models (the bearing model has no solver cell)")
        if opts.exact_bearing:
            res = _bearing_exact(heights, axes, tol, opts.on_unbracketed)
            return res if axis is None else res[axes[0]]

        def evaluate_bearing(a: float, init, scout: bool) -> _Sample:
            # ties: a cut tie group is taken whole, and only one inside a bracket of the
            # end matters (the ``tie`` hook below), not a warning at every solve
            return sample(solve_bearing(heights, a, warn_ties=False), a, -heights, None)

        res = _refine(evaluate_bearing, axes, tol=tol, first=0.5, load_range=law.bounds,
                      law=law, options=dataclasses.replace(opts, warm_start=False),
                      model=model, loads_are_pressures=False, tie=_bearing_tie(heights))
        return res if axis is None else res[axes[0]]

    kwargs = {"model": model, "method": opts.method, "adhesion": adhesion, "threads": threads,
              "tol": opts.contact_tol, "backend": backend}
    if cap is not None:
        kwargs["hardness"] = cap
    start_out = None
    if model == "elastic" and kwargs["method"] in (None, "gfmd"):  # built once for all solves
        kwargs["setup"] = prepare(surface, threads, backend)
        if lean:
            if not on_gpu:  # on the GPU the solver's arrays come from CuPy's memory pool
                kwargs["work"] = workspace(surface)
            # the warm starts' gap, pressure and contact
            start_out = (np.empty(shape), np.empty(shape), np.empty(shape, dtype=bool))

    scout_tol = min(SCOUT_TOL_FACTOR * opts.contact_tol, CONTACT_TOL_MAX)

    def evaluate(p: float, init: ContactResult | None, scout: bool) -> _Sample:
        args = dict(kwargs, tol=scout_tol) if scout else kwargs
        r = timed_solve(lambda p, init: solve(surface, p, init=init, **args), p, init,
                        what=f"threshold ({model}) solve")  # a scout shows its residual
        return dataclasses.replace(sample(r, p, None, r.contact_pressure), scout=scout)

    first = (_capped_first(first_pressure(model), cap) if opts.first_pressure is None
             else float(opts.first_pressure))
    try:
        res = _refine(evaluate, axes, tol=tol, first=first, load_range=opts.pressure_range,
                      law=law, options=opts, model=model, loads_are_pressures=True,
                      compliance=compliance,
                      scouts=model == "elastic" and scout_tol > opts.contact_tol,
                      start_out=start_out, top_note=top_note)
    except ThresholdNotBracketed as exc:
        if options is None or not gbar > 0 or 0.5 <= gbar <= 2.0:
            raise
        raise ThresholdNotBracketed(
            f"{exc}; the surface's rms gradient is {gbar:.3g}, and the given "
            "options' pressures are in E*: search.scaled_options(surface.gbar, model, ...) "
            "scales the default range to it") from None
    if cap is not None:  # the perimeter correction is calibrated on elastic contacts only
        res = {ax: dataclasses.replace(t, hardness=cap, a_c_star_corrected=float("nan"))
               for ax, t in res.items()}
    return res if axis is None else res[axes[0]]
