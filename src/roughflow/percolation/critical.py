"""Critical contact area a_c* per flow direction (paper Sect. 2.2 and 3.2).

a_c*(axis) is the relative contact area at which the fluid (open, 4-connected) stops
spanning the cell along ``axis`` (open boundaries along it, periodic across).

- ``model="bearing"``: exact. Contact is the top fraction of heights, so the open set grows
  from the lowest cell up; one union-find pass over the cells sorted by height
  (:func:`roughflow.percolation.sweep.critical_open_count`) gives the number of open cells
  at which the fluid first spans. The bracket is one cell wide (1/N), wider only where
  heights tie.
- ``model="elastic"`` / ``"adhesive"``: a bracket in pressure, refined with warm-started
  contact solves until the contact areas at the two ends differ by at most ``tol``. Both
  axes come from one shared sequence of solves. The default ``strategy="predict"`` aims
  each solve with a first-order prediction taken from the nearest solved state: its cells
  ordered from the most open (largest gap) to the most closed (largest contact pressure)
  are swept with union-find, which gives the area at which that ordering stops spanning
  (exact for the bearing model, first order for elastic contacts). f(a) = prediction - a
  is > 0 on every spanning state and < 0 on every blocked one; once both sides are known
  the next target is the secant root of f between them, and the pressure is placed 0.3 tol
  on the far side of it (a safeguarded bisection takes over whenever a step fails to
  halve the bracket).
  ``strategy="bisect"`` is plain bisection in a_c (pressure interpolated), the naive
  reference.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy.special import erfinv

from roughflow.accuracy import PERIMETER_C, perimeter_term
from roughflow.errors import ConvergenceError, InputError, require_positive
from roughflow.surface import Surface

from .labels import check_axis
from .spanning import percolates
from .sweep import critical_open_count

MODELS = ("elastic", "adhesive", "bearing")
STRATEGIES = ("predict", "bisect")
#: First guess of a_c* (paper: 0.415 +- 0.01 for elastic contacts).
A_GUESS = 0.415
#: Small-load Persson-like model a = erf(c p); c = sqrt(pi) reproduces the simulated
#: small-load slope da/dp = 2 (physics notes Sect. 6). Used only to place the first solve
#: and to extrapolate beyond the solved states.
_C_ELASTIC = math.sqrt(math.pi)


class ThresholdNotBracketed(InputError):
    """The fluid spans (or never spans) over the whole allowed pressure range."""


@dataclass(frozen=True)
class Threshold:
    """Critical contact area for fluid flow along ``axis`` (0 = x, 1 = y).

    The fluid spans at ``a_lo`` (pressure ``p_lo``) and does not at ``a_hi`` (``p_hi``);
    ``a_c_star`` is the midpoint. Pressures are in E* gbar (NaN for the bearing model,
    which is parameterised by the area itself). ``n_solves`` counts the contact solves
    of the whole call (shared between the axes when both were asked for).
    ``bracketed`` is False when the allowed pressure range did not contain the threshold
    (only returned with ``on_unbracketed="nan"``; then ``a_c_star`` is NaN and only the
    side that was found is set).
    ``a_c_star_corrected`` removes the first-order grid bias of the elastic contact area
    (:func:`roughflow.accuracy.perimeter_corrected_area` applied to both bracketing states;
    docs/accuracy.md: +0.032 raw bias at 4 points per lambda_s, +0.004 after correction).
    For the bearing model the cell count of a level set is unbiased and it equals
    ``a_c_star``; for the adhesive model the constant is not calibrated and it is NaN.
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
    solves: tuple = field(default=(), repr=False)  # (pressure, a_c, iterations, residual)
    a_c_star_corrected: float = float("nan")

    @property
    def width(self) -> float:
        return self.a_hi - self.a_lo


@dataclass
class _Sample:
    s: float  # control parameter: pressure (elastic/adhesive) or area fraction (bearing)
    a: float
    spans: dict
    predictor: Callable[[], dict] | None = None  # computed on first use (sort + sweep)
    state: object = None
    _pred: dict | None = None
    perimeter: float = float("nan")  # perimeter term of the contact set (accuracy module)

    @property
    def pred(self) -> dict:
        if self._pred is None:
            self._pred = self.predictor() if self.predictor is not None else {}
        return self._pred


# ---------------------------------------------------------------------------------------
# bearing model: exact sweep
# ---------------------------------------------------------------------------------------

def _bearing_exact(h: np.ndarray, axes: tuple[int, ...], tol: float, on_unbracketed: str):
    n = h.size
    flat = h.ravel()
    order = np.argsort(flat, kind="stable")  # the lowest cells open first
    hs = flat[order]
    out = {}
    for ax in axes:
        k = critical_open_count(order, h.shape, ax)
        # Cells of equal height open together: widen the bracket over the tie group.
        i0 = int(np.searchsorted(hs, hs[k - 1], side="left"))
        i1 = int(np.searchsorted(hs, hs[k - 1], side="right"))
        a_lo, a_hi = 1.0 - i1 / n, 1.0 - i0 / n
        msg = ""
        ok = i1 - i0 == 1 or a_hi - a_lo <= tol  # one cell: exact at grid resolution
        if not ok:
            msg = (
                f"{i1 - i0} cells share the critical height {float(hs[k - 1])!r}: the threshold "
                f"along axis {ax} is only known to lie in [{a_lo:.6g}, {a_hi:.6g}], wider "
                f"than tol={tol:g}"
            )
            if on_unbracketed == "raise":
                raise ThresholdNotBracketed(msg)
        out[ax] = Threshold(
            axis=ax, a_c_star=0.5 * (a_lo + a_hi) if ok else float("nan"), a_lo=a_lo,
            a_hi=a_hi, p_lo=float("nan"), p_hi=float("nan"), n_solves=0, model="bearing",
            tol=tol, bracketed=ok, message=msg,
            a_c_star_corrected=0.5 * (a_lo + a_hi) if ok else float("nan"),
        )
    return out


# ---------------------------------------------------------------------------------------
# elastic / adhesive: bracket refinement shared between axes
# ---------------------------------------------------------------------------------------

def _open_first_order(gap: np.ndarray, contact: np.ndarray, pressure: np.ndarray) -> np.ndarray:
    """Flat indices: open cells by decreasing gap, then contact cells by increasing pressure."""
    flat_c = contact.ravel()
    idx_open = np.flatnonzero(~flat_c)
    idx_cont = np.flatnonzero(flat_c)
    o = idx_open[np.argsort(-gap.ravel()[idx_open])]
    c = idx_cont[np.argsort(pressure.ravel()[idx_cont])]
    return np.concatenate([o, c])


def _predict(order: np.ndarray, shape, n_open: int, axes) -> tuple[dict, dict]:
    """Spanning of the current state and the predicted a_c* for each axis."""
    n = order.size
    spans, pred = {}, {}
    for ax in axes:
        k = critical_open_count(order, shape, ax)
        spans[ax] = k <= n_open
        pred[ax] = 1.0 - (k - 0.5) / n
    return spans, pred


def _bracket(samples: list[_Sample], ax: int):
    his = [q for q in samples if not q.spans[ax]]
    hi = min(his, key=lambda q: q.s) if his else None
    los = [q for q in samples if q.spans[ax] and (hi is None or q.s < hi.s)]
    lo = max(los, key=lambda q: q.s) if los else None
    return lo, hi


def _s_for_area(target: float, samples: list[_Sample], lo, hi, extrapolate, s_range) -> float:
    """Control value expected to give area ``target``: linear interpolation between the
    solves that straddle it, else linear extrapolation from the two nearest solves on that
    side (``extrapolate``, a model, when there is only one); kept inside the bracket."""
    srt = sorted(samples, key=lambda q: q.s)
    s = None
    for q0, q1 in zip(srt[:-1], srt[1:], strict=True):
        if (q0.a - target) * (q1.a - target) <= 0 and q0.a != q1.a:
            s = q0.s + (target - q0.a) / (q1.a - q0.a) * (q1.s - q0.s)
            break
    if s is None:
        side = [q for q in srt if (q.a < target) == (srt[0].a < target)]
        up = target > side[0].a  # ties in a: prefer the solves farthest in that direction
        near = sorted(side, key=lambda q: (abs(q.a - target), -q.s if up else q.s))[:2]
        if len(near) == 2 and near[0].a != near[1].a and \
                (near[0].s - near[1].s) * (near[0].a - near[1].a) > 0:
            q0, q1 = near
            s = q0.s + (target - q0.a) / (q1.a - q0.a) * (q1.s - q0.s)
        else:
            s = extrapolate(target, near[0])
    s = min(max(s, s_range[0]), s_range[1])
    lo_s = lo.s if lo is not None else s_range[0]
    hi_s = hi.s if hi is not None else s_range[1]
    s = min(max(s, lo_s), hi_s)
    if any(abs(s - q.s) <= 1e-12 * max(abs(s), 1e-300) for q in srt):
        s = 0.5 * (lo_s + hi_s)
    return s


def _interpolated_state(q0: _Sample, q1: _Sample, s: float):
    """Contact state linearly interpolated (in the control value) between two solves.

    Only the fields a warm start reads are interpolated (contact pressure, displacement);
    the result is a starting guess, never reported.
    """
    r0, r1 = q0.state, q1.state
    t = (s - q0.s) / (q1.s - q0.s)
    kw = {}
    for name in ("contact_pressure", "displacement"):
        f0, f1 = getattr(r0, name, None), getattr(r1, name, None)
        if isinstance(f0, np.ndarray) and isinstance(f1, np.ndarray):
            kw[name] = (1.0 - t) * f0 + t * f1
    if not kw:
        return r0 if abs(t) <= abs(1 - t) else r1
    return dataclasses.replace(r0, **kw)


def _warm_start(samples: list[_Sample], s: float):
    """Initial state for a solve at ``s``: interpolated between the nearest solves on both
    sides, else extrapolated linearly from the two nearest solves (the contact solver
    clips negative pressures and rescales to the load)."""
    if not samples:
        return None
    below = [q for q in samples if q.s < s]
    above = [q for q in samples if q.s > s]
    if below and above:
        q0 = max(below, key=lambda q: q.s)
        q1 = min(above, key=lambda q: q.s)
    else:  # extrapolate from the two nearest solves, by at most their spacing
        near = sorted(samples, key=lambda q: abs(q.s - s))
        if len(near) < 2 or abs(s - near[0].s) > abs(near[1].s - near[0].s):
            return near[0].state
        q0, q1 = sorted(near[:2], key=lambda q: q.s)
    if dataclasses.is_dataclass(q0.state) and type(q0.state) is type(q1.state):
        return _interpolated_state(q0, q1, s)
    return min(samples, key=lambda q: abs(q.s - s)).state


def _refine(
    evaluate: Callable[[float, object], _Sample],
    axes: tuple[int, ...],
    *,
    tol: float,
    s_first: float,
    s_range: tuple[float, float],
    strategy: str,
    extrapolate: Callable[[float, _Sample], float],
    max_solves: int,
    warm: bool,
    model: str,
    on_unbracketed: str,
    s_is_pressure: bool,
) -> dict:
    samples: list[_Sample] = []
    misses = {ax: 0 for ax in axes}  # consecutive solves that missed the intended side
    intended: dict = {}  # axis -> (number of samples before the solve, intended spans)
    unbracketed: dict = {}

    def run(s: float) -> None:
        samples.append(evaluate(s, _warm_start(samples, s) if warm else None))

    run(min(max(s_first, s_range[0]), s_range[1]))
    while True:
        last = samples[-1]
        for ax, (n_before, want) in list(intended.items()):
            if n_before == len(samples) - 1:
                misses[ax] = misses[ax] + 1 if last.spans[ax] != want else 0
        intended.clear()
        todo = []
        for ax in axes:
            if ax in unbracketed:
                continue
            lo, hi = _bracket(samples, ax)
            if lo is not None and hi is not None:
                w = hi.a - lo.a
                if w <= tol:
                    continue
                todo.append((w, ax, lo, hi))
            elif lo is None and hi is not None and hi.s <= s_range[0]:
                unbracketed[ax] = (lo, hi, f"the fluid does not span along axis {ax} even at "
                                   f"the lowest allowed pressure {s_range[0]:g} "
                                   f"(a_c = {hi.a:.4g})")
            elif hi is None and lo is not None and lo.s >= s_range[1]:
                unbracketed[ax] = (lo, hi, f"the fluid still spans along axis {ax} at the "
                                   f"highest allowed pressure {s_range[1]:g} "
                                   f"(a_c = {lo.a:.4g})")
            else:
                q = lo if lo is not None else hi
                dist = abs(q.pred[ax] - q.a) if strategy == "predict" else 0.0
                todo.append((math.inf, ax, lo, hi, dist))
        if not todo:
            break
        if len(samples) >= max_solves:
            w, ax = max((t[0], t[1]) for t in todo)
            tried = ", ".join(f"({q.s:.4g}, {q.a:.4g})" for q in samples[-4:])
            raise ConvergenceError(
                f"threshold along axis {ax} not resolved to tol={tol:g} within "
                f"max_solves={max_solves} contact solves; last (control, a_c): {tried}; "
                "residual = bracket width", residual=float(w), iterations=len(samples),
            )
        # Work on an open-ended bracket first (the one predicted nearest), else on the
        # widest bracket; every solve updates all axes.
        open_ended = [t for t in todo if t[0] == math.inf]
        if open_ended:
            _, ax, lo, hi, _ = min(open_ended, key=lambda t: (t[4], t[1]))
        else:
            w, ax, lo, hi = max(todo, key=lambda t: (t[0], -t[1]))
        m = misses[ax]
        if lo is not None and hi is not None:
            if hi.s - lo.s <= 1e-12 * hi.s:
                raise ConvergenceError(
                    f"contact area jumps from {lo.a:.6g} to {hi.a:.6g} between pressures "
                    f"{lo.s:.12g} and {hi.s:.12g}: threshold along axis {ax} cannot be "
                    f"resolved to tol={tol:g}", residual=float(w), iterations=len(samples),
                )
            if strategy == "bisect" or m >= 3:
                target = 0.5 * (lo.a + hi.a)
                want = None
            else:
                # Secant root of f(a) = predicted a_c* - a, which is > 0 on every spanning
                # state and < 0 on every blocked one, so its root lies inside the bracket.
                # (Inverse quadratic interpolation and one-sided secant steps were tried:
                # no fewer solves over 20 seeds.)
                # Aim just past it on the side that leaves the shorter bracket; the offset
                # doubles after each miss.
                f_lo, f_hi = lo.pred[ax] - lo.a, hi.pred[ax] - hi.a
                est = lo.a + f_lo * (hi.a - lo.a) / (f_lo - f_hi)
                off = 0.3 * tol * 2.0**m
                t_lo, t_hi = est - off, est + off
                want = hi.a - t_lo < t_hi - lo.a  # True: expect a new spanning state
                target = t_lo if want else t_hi
                target = min(max(target, lo.a + 0.05 * w), hi.a - 0.05 * w)
        elif hi is None:
            want = False
            if strategy == "bisect":
                target = lo.a + 0.05 * 2.0**m
            else:
                # One-sided: overshoot the prediction by a quarter of the predicted
                # distance (predictions are good to a few tens of percent) plus an offset.
                d = max(lo.pred[ax] - lo.a, 0.0)
                target = lo.a + 1.25 * d + 0.5 * tol * 2.0**m
            target = min(target, 0.5 * (1.0 + lo.a))
        else:
            want = True
            if strategy == "bisect":
                target = hi.a - 0.05 * 2.0**m
            else:
                d = max(hi.a - hi.pred[ax], 0.0)
                target = hi.a - 1.25 * d - 0.5 * tol * 2.0**m
            target = max(target, 0.5 * hi.a)
        if want is not None:
            intended[ax] = (len(samples), want)
        run(_s_for_area(target, samples, lo, hi, extrapolate, s_range))

    n = len(samples)
    log = tuple((q.s, q.a, getattr(q.state, "iterations", 0),
                 float(getattr(q.state, "residual", 0.0))) for q in samples)
    nan = float("nan")
    out = {}
    for ax in axes:
        if ax in unbracketed:
            lo, hi, msg = unbracketed[ax]
            if on_unbracketed == "raise":
                raise ThresholdNotBracketed(msg + f" after {n} contact solves")
            out[ax] = Threshold(
                axis=ax, a_c_star=nan, a_lo=lo.a if lo else nan, a_hi=hi.a if hi else nan,
                p_lo=lo.s if lo and s_is_pressure else nan,
                p_hi=hi.s if hi and s_is_pressure else nan, n_solves=n, model=model,
                tol=tol, bracketed=False, message=msg, solves=log,
            )
            continue
        lo, hi = _bracket(samples, ax)
        corrected = 0.5 * (lo.a + hi.a) - 0.5 * PERIMETER_C * (lo.perimeter + hi.perimeter)
        out[ax] = Threshold(
            axis=ax, a_c_star=0.5 * (lo.a + hi.a), a_lo=lo.a, a_hi=hi.a,
            p_lo=lo.s if s_is_pressure else nan, p_hi=hi.s if s_is_pressure else nan,
            n_solves=n, model=model, tol=tol, solves=log,
            a_c_star_corrected=corrected if model == "elastic" else nan,
        )
    return out


def first_guess_pressure(model: str = "elastic") -> float:
    """First pressure tried (E* gbar): a = erf(sqrt(pi) p) solved at a = 0.415; a quarter
    of that for the adhesive model (physics notes 3.3: adhesion needs about 1/4 of the
    load for 40 % contact)."""
    p = float(erfinv(A_GUESS)) / _C_ELASTIC
    return 0.25 * p if model == "adhesive" else p


# ---------------------------------------------------------------------------------------
# public entry point
# ---------------------------------------------------------------------------------------

def threshold(
    surface: Surface,
    axis: int | None = None,
    *,
    model: str = "elastic",
    tol: float = 2e-3,
    method: str | None = None,
    strategy: str = "predict",
    adhesion=None,
    p_guess: float | None = None,
    p_range: tuple[float, float] = (1e-4, 4.0),
    contact_tol: float | None = 1e-5,
    max_solves: int = 40,
    warm_start: bool = True,
    exact_bearing: bool = True,
    on_unbracketed: str = "raise",
    threads: int | None = None,
) -> Threshold | dict[int, Threshold]:
    """Critical contact area a_c* for fluid flow along ``axis`` (0 = x, 1 = y).

    ``axis=None`` returns ``{0: Threshold, 1: Threshold}`` from one shared sequence of
    contact solves. ``tol`` is the largest allowed ``a_hi - a_lo``.

    model: ``"elastic"`` (default), ``"adhesive"`` (needs ``adhesion=``) or ``"bearing"``.
    method: contact method passed to :func:`roughflow.contact.solve`; for the bearing
        model ``exact_bearing=False`` bisects in the area fraction instead of the exact
        sweep (for validation).
    strategy: ``"predict"`` (default) or ``"bisect"`` (plain bisection in a_c; the naive
        reference, with ``warm_start=False`` and one axis per call for the cold baseline).
    p_guess: first pressure (E* gbar); default from a = erf(sqrt(pi) p) at a = 0.415
        (a quarter of that for the adhesive model).
    p_range: allowed pressures; a surface whose fluid spans at ``p_range[1]`` or never
        spans at ``p_range[0]`` is unbracketed: :class:`ThresholdNotBracketed` (an
        :class:`InputError`) is raised, or with ``on_unbracketed="nan"`` a result with
        ``bracketed=False`` and ``a_c_star`` NaN is returned.
    contact_tol: ``tol`` of each contact solve (largest gap error / rms height; default
        1e-5: contact masks then agree cell by cell with a 1e-8 solve in our checks at
        256^2 and 512^2, while warm starts need fewer iterations than at 1e-6; None uses
        the contact stage's default).
    max_solves: cap on contact solves; exceeding it raises :class:`ConvergenceError`.
    """
    if not isinstance(surface, Surface):
        raise InputError(f"surface must be a roughflow Surface, got {type(surface).__name__}")
    axes = (0, 1) if axis is None else (check_axis(axis),)
    if model not in MODELS:
        raise InputError(f"model must be one of {MODELS}, got {model!r}")
    if strategy not in STRATEGIES:
        raise InputError(f"strategy must be one of {STRATEGIES}, got {strategy!r}")
    tol = require_positive("tol", tol)
    if tol >= 1:
        raise InputError(f"tol must be below 1 (a contact-area difference), got {tol!r}")
    if on_unbracketed not in ("raise", "nan"):
        raise InputError(f"on_unbracketed must be 'raise' or 'nan', got {on_unbracketed!r}")
    if isinstance(max_solves, bool) or not isinstance(max_solves, (int, np.integer)) or \
            max_solves < 2:
        raise InputError(f"max_solves must be an integer >= 2, got {max_solves!r}")
    try:
        p_min, p_max = (float(v) for v in p_range)
    except (TypeError, ValueError):
        raise InputError(f"p_range must be a pair (p_min, p_max), got {p_range!r}") from None
    if not (math.isfinite(p_min) and math.isfinite(p_max) and p_min < p_max):
        raise InputError(f"p_range must be finite with p_min < p_max, got {p_range!r}")
    if model == "elastic" and p_min <= 0:
        raise InputError(f"p_range must be positive for the elastic model, got {p_range!r}")
    if model == "adhesive" and adhesion is None:
        raise InputError("model='adhesive' needs adhesion=Adhesion(surface_energy=, range=)")
    heights = surface.heights
    shape = heights.shape

    def _sample(r, s, phi_open_first, pressure):
        opn = ~r.contact
        spans = {ax: percolates(opn, ax) for ax in axes}
        predictor = None
        if strategy == "predict":
            def predictor():
                if phi_open_first is not None:
                    order = np.argsort(-phi_open_first, axis=None)
                else:
                    order = _open_first_order(r.gap, r.contact, pressure)
                return _predict(order, shape, int(opn.sum()), axes)[1]
        perimeter = (perimeter_term(r.contact, surface.lx, surface.ly) if model == "elastic"
                     else float("nan"))
        return _Sample(s=float(s), a=float(r.area_fraction), spans=spans, predictor=predictor,
                       state=r, perimeter=perimeter)

    if model == "bearing":
        if exact_bearing:
            res = _bearing_exact(np.asarray(heights, dtype=np.float64), axes, tol,
                                 on_unbracketed)
            return res if axis is None else res[axes[0]]
        from roughflow.contact import solve

        def evaluate_bearing(a: float, init) -> _Sample:
            r = solve(surface, model="bearing", area_fraction=a)
            return _sample(r, a, -heights, None)

        res = _refine(
            evaluate_bearing, axes, tol=tol, s_first=0.5, s_range=(0.0, 1.0),
            strategy=strategy, extrapolate=lambda t, q: t, max_solves=max_solves,
            warm=False, model=model, on_unbracketed=on_unbracketed, s_is_pressure=False,
        )
        return res if axis is None else res[axes[0]]

    from roughflow.contact import solve

    kwargs = {"model": model, "method": method, "adhesion": adhesion, "threads": threads}
    if contact_tol is not None:
        kwargs["tol"] = require_positive("contact_tol", contact_tol)

    def evaluate(p: float, init) -> _Sample:
        r = solve(surface, p, init=init, **kwargs)
        return _sample(r, p, None, r.contact_pressure)

    def extrapolate(target: float, q: _Sample) -> float:
        t = min(max(target, 1e-6), 1 - 1e-6)
        if 0 < q.a < 1 and q.s > 0:
            return q.s * float(erfinv(t) / erfinv(q.a))
        return q.s * (2.0 if target > q.a else 0.5)

    if p_guess is None:
        p_guess = first_guess_pressure(model)
    p_guess = float(p_guess)
    if not math.isfinite(p_guess):
        raise InputError(f"p_guess must be finite, got {p_guess!r}")

    res = _refine(
        evaluate, axes, tol=tol, s_first=p_guess, s_range=(p_min, p_max), strategy=strategy,
        extrapolate=extrapolate, max_solves=int(max_solves), warm=warm_start, model=model,
        on_unbracketed=on_unbracketed, s_is_pressure=True,
    )
    return res if axis is None else res[axes[0]]
