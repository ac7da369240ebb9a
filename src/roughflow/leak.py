"""The leak question of a surface: contact, percolation and Reynolds flow over a list of
nominal pressures, and the sealing pressure (paper Sect. 2.1, Eq. 3-4; docs/measured.md).

:func:`leak_curve` works in the dimensionless system (E* = 1, lengths in L, eta = 1;
pressures in E*, which is E* gbar for generated surfaces with rms gradient 1); the
physical conversion is :class:`roughflow.units.Scales` and
:func:`roughflow.units.leak_rate`, and :func:`roughflow.datasets.leak_dataset` writes both.

A non-periodic scan goes through :func:`roughflow.boundary.embed` (default
:data:`~roughflow.defaults.BOUNDARY`); a periodic surface is analysed as it is. A nominal
pressure high enough to close every gap is an answer (a_c = 1, no percolation, sigma = 0),
not a failure.
"""

from __future__ import annotations

import dataclasses
import logging
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from roughflow import flow
from roughflow._repr import summary_repr
from roughflow.boundary import Embedding, embed
from roughflow.contact import (
    ContactResult,
    check_contact_tol,
    check_hardness,
    check_pressure_scale,
    check_resolved_load,
    require_below_hardness,
    resolved_load_floor,
    solve,
)
from roughflow.defaults import (
    BOUNDARY,
    CONTACT_TOL,
    FLOW_SIGMA_TOL,
    FLOW_TOL,
    LARGE_STRAIN_PRESSURE,
    LEAK_MIN_CONTACT_CELLS,
    THRESHOLD_CONTACT_TOL,
    THRESHOLD_TOL,
)
from roughflow.errors import InputError, require_positive
from roughflow.flow import check_sigma_tol
from roughflow.resources import check_memory
from roughflow.search import SearchOptions, Threshold, scaled_options, threshold
from roughflow.search.critical import check_area_tol
from roughflow.surface import Surface
from roughflow.units import canonical

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from roughflow.units import Scales

__all__ = ["LeakCurve", "check_pressures", "check_seal", "fluid_pressure_note", "fluid_lifted_rows",
           "default_boundary", "lowest_resolved_pressure", "sealing_search", "leak_curve",
           "pressure_curve", "EMPTY_WINDOW_WARNING", "empty_window_rows",
           "empty_window_pressures", "FEW_CELLS_WARNING", "contact_cells", "few_cell_rows",
           "few_cell_pressures", "LARGE_STRAIN_WARNING", "large_strain"]

log = logging.getLogger(__name__)

#: Relative slack of the pressure comparisons below: pressures come back from units of E*
#: an ulp off (1 MPa as 1000000.0000000001 Pa), and a pressure equal to a bound counts as
#: at it.
_ROUND_OFF = 1e-9


@dataclass(frozen=True, eq=False)
class LeakCurve:
    """Results per nominal pressure (arrays over ``pressure``; ``[:, axis]`` per flow
    direction, 0 = x, 1 = y) and the sealing thresholds, all dimensionless.

    pressure: nominal contact pressures on the analysed surface (E*).
    area_fraction, mean_gap: relative contact area and mean gap (L) of the analysed window.
    percolating: whether the fluid spans the window along each axis.
    sigma: effective conductance per axis, u^3/(12 eta) in L^3/eta (0 without percolation).
    iterations, residual: of each contact solve.
    flow_imbalance, flow_sigma_error: of each flow solve (``FlowResult.flux_imbalance`` and
        ``sigma_error``: an upper bound on sigma's relative error from the linear solve); 0
        without percolation.
    thresholds: per axis, the percolation threshold search on the same window; its
        ``p_lo`` / ``p_hi`` are nominal pressures (E*): the fluid spans at ``p_lo`` and not
        at ``p_hi``, so the seal closes along that axis between them.
    boundary: the non-periodic treatment (:mod:`roughflow.boundary`).
    rms_gradient: of the surface (its pressures are in E*; E* gbar only when it is 1).
    window_lx, window_ly, window_shape: size (L) and grid of the analysed window.
    settings: the tolerances used, and ``sealing_searched`` (1, or 0 with ``sealing=False``);
        ``hardness`` (E*) where the rows (and the sealing search) were solved with one.
    plastic_fraction: with a ``hardness``, the plastic share of the analysed window per
        row (cells at the cap; part of ``area_fraction``); None without.
    An ``area_fraction`` of exactly 0 marks a row whose analysed window holds no contact
    (:func:`empty_window_pressures`), one of fewer than
    :data:`~roughflow.defaults.LEAK_MIN_CONTACT_CELLS` window cells an under-resolved one
    (:func:`few_cell_pressures`; the count is :func:`contact_cells`).
    """

    __repr__ = summary_repr

    pressure: np.ndarray
    area_fraction: np.ndarray
    mean_gap: np.ndarray
    percolating: np.ndarray
    sigma: np.ndarray
    iterations: np.ndarray
    residual: np.ndarray
    flow_imbalance: np.ndarray
    flow_sigma_error: np.ndarray
    thresholds: dict[int, Threshold]
    boundary: str
    rms_gradient: float
    window_lx: float
    window_ly: float
    window_shape: tuple[int, int]
    settings: dict = field(default_factory=dict)
    plastic_fraction: np.ndarray | None = None


def check_pressures(pressures: ArrayLike) -> np.ndarray:
    """Nominal pressures as a strictly increasing array of positive numbers."""
    p = np.atleast_1d(np.asarray(pressures, dtype=np.float64))
    if p.ndim != 1 or p.size == 0:
        raise InputError(f"pressures must be a non-empty list, got {pressures!r}")
    for v in p:
        require_positive("pressure", v)
    if np.any(np.diff(p) <= 0):
        raise InputError(f"pressures must increase strictly, got {p.tolist()}")
    return p


def check_seal(surface: Surface, scales: Scales, *, fluid_pressure: float,
               seal_width: float, seal_length: float) -> None:
    """:class:`InputError` naming the value unless the seal's ``fluid_pressure`` (Pa),
    ``seal_width`` and ``seal_length`` (m) are positive and finite, and ``scales.length`` is
    the surface's own L where it records one (an imported scan keeps its physical size).
    ``roughflow leak`` and :func:`roughflow.datasets.leak_dataset` both check with it."""
    for name, v in (("fluid_pressure (Pa)", fluid_pressure), ("seal_width (m)", seal_width),
                    ("seal_length (m)", seal_length)):
        require_positive(name, v)
    if surface.scan is None:
        return
    own = surface.scan.length_scale
    # compared to the digits a quantity keeps (units.canonical): "0.125um" and "125nm" agree
    if canonical(scales.length) != canonical(own):
        raise InputError(
            f"the length scale {scales.length!r} m contradicts the scan's own L = {own!r} m "
            f"(an imported scan keeps its physical size; a wrong L scales the leak rate by its "
            f"cube): use Scales(length=surface.scan.length_scale, ...)")


def fluid_lifted_rows(pressures: ArrayLike, fluid_pressure: float) -> np.ndarray:
    """Per row: whether the nominal contact pressure (``pressures``, in the unit of
    ``fluid_pressure``) is at or below the fluid's pressure drop: on the seal's high-pressure
    side the fluid would push the faces apart, and the model, which leaves the fluid's load
    on the faces out, does not hold. A pressure equal to the fluid's but for round-off
    counts as at it."""
    p = np.asarray(pressures, dtype=np.float64)
    return p * (1.0 - _ROUND_OFF) <= float(fluid_pressure)


def fluid_pressure_note(fluid_pressure: float, pressures: ArrayLike, unit: str = "") -> str:
    """A note where the fluid's pressure drop ``fluid_pressure`` is not small against the
    lowest nominal contact pressure of ``pressures`` (both in ``unit``), else "".

    The Reynolds flow here leaves the fluid's own load on the surfaces out, which holds for
    dp << p; at the pressures where it does not, the leak rates overstate the contact. The
    note is there where some row is at or below the fluid pressure
    (:func:`fluid_lifted_rows`, which the leak table marks), and is about the rows above
    it."""
    lowest = float(np.min(pressures))
    if not fluid_lifted_rows(pressures, fluid_pressure).any():
        return ""
    u = f" {unit}" if unit else ""
    return (f"the fluid pressure {fluid_pressure:.4g}{u} is not small against the lowest "
            f"contact pressure {lowest:.4g}{u}: the model leaves the fluid's load on the "
            f"surfaces out (it holds for dp << p); read the leak rates at contact pressures "
            f"not far above {fluid_pressure:.4g}{u} with care")


def default_boundary(surface: Surface) -> str:
    """:data:`~roughflow.defaults.BOUNDARY` for a non-periodic scan, ``"periodic"`` else."""
    return "periodic" if surface.periodic else BOUNDARY


def large_strain(pressure: ArrayLike) -> np.ndarray:
    """Whether a nominal pressure (E*; a number or an array of them, e.g. a leak curve's
    rows or a sealing pressure) is at or above
    :data:`~roughflow.defaults.LARGE_STRAIN_PRESSURE` E*: strains of order one, outside the
    linear-elastic contact model (the reasons are there). Solved all the same; the leak
    table and ``roughflow contact`` flag it."""
    return np.asarray(pressure, dtype=np.float64) >= LARGE_STRAIN_PRESSURE * (1.0 - _ROUND_OFF)


def lowest_resolved_pressure(surface: Surface, boundary: str | None = None) -> float:
    """The lowest nominal pressure (E*) :func:`leak_curve` takes on ``surface`` with
    ``boundary`` (default :func:`default_boundary`): the solver cell's
    :func:`~roughflow.contact.solve.resolved_load_floor` as a pressure on the analysed
    part (a lower one is refused, as ``contact.solve`` refuses it)."""
    return _lowest_resolved(embed(surface, default_boundary(surface) if boundary is None
                                  else boundary))


def _lowest_resolved(emb: Embedding) -> float:
    """:func:`lowest_resolved_pressure` of the embedding ``emb``."""
    return emb.nominal_pressure(resolved_load_floor(emb.surface.gbar, emb.surface.shape))


def _pressures_text(pressures: ArrayLike, modulus: float | None, sep: str = ", ") -> str:
    """Nominal pressures (E*) for a message, "0.0001, 0.001 E*"; with ``modulus`` (E* in
    Pa) also in pascals, "0.0001, 0.001 E* = 1e+05, 1e+06 Pa"."""
    p = np.atleast_1d(np.asarray(pressures, dtype=np.float64))
    text = sep.join(f"{v:.4g}" for v in p) + " E*"
    if modulus is not None:
        text += " = " + sep.join(f"{v * modulus:.4g}" for v in p) + " Pa"
    return text


def _sealing_options(emb: Embedding, *, gbar: float, contact_tol: float,
                     hardness: float | None) -> SearchOptions:
    """The options of :func:`sealing_search` (checked as they are made)."""
    return scaled_options(gbar * emb.load_factor, "elastic", contact_tol=contact_tol,
                          on_unbracketed="nan", observe=emb.observe, observed_shape=emb.shape,
                          periodic=emb.periodic, hardness=hardness)


def sealing_search(emb: Embedding, *, gbar: float, tol: float = THRESHOLD_TOL,
                   contact_tol: float = THRESHOLD_CONTACT_TOL, threads: int | None = None,
                   hardness: float | None = None) -> dict[int, Threshold]:
    """Percolation thresholds of the analysed window along x and y, with the bracketing
    pressures converted to nominal ones. The search's pressure range and first pressure
    (:mod:`roughflow.defaults`, in E* gbar) are scaled by the surface's rms gradient
    ``gbar`` and the embedding's load factor; an unbracketed axis gets NaN and a message.
    ``hardness`` (E*): the solver cell's contact pressure capped there
    (:attr:`roughflow.search.SearchOptions.hardness`: elastic-perfectly-plastic; the
    range's cell pressures end below it), so the thresholds are the capped contact's."""
    opts = _sealing_options(emb, gbar=gbar, contact_tol=contact_tol, hardness=hardness)
    res = threshold(emb.surface, None, tol=tol, options=opts, threads=threads)
    return {ax: dataclasses.replace(t, p_lo=emb.nominal_pressure(t.p_lo),
                                    p_hi=emb.nominal_pressure(t.p_hi))
            for ax, t in res.items()}


def leak_curve(surface: Surface, pressures: ArrayLike, *, boundary: str | None = None,
               contact_tol: float = CONTACT_TOL, flow_tol: float = FLOW_TOL,
               flow_sigma_tol: float | None = FLOW_SIGMA_TOL,
               threshold_tol: float = THRESHOLD_TOL,
               threshold_contact_tol: float = THRESHOLD_CONTACT_TOL,
               sealing: bool = True, threads: int | None = None,
               hardness: float | None = None, modulus: float | None = None) -> LeakCurve:
    """Contact, percolation along x and y, and Reynolds conductances of ``surface`` at each
    nominal pressure (E*, increasing; each solve warm-starts from the previous one), and
    the sealing thresholds (:func:`sealing_search`, skipped with ``sealing=False``).

    ``boundary``: :data:`~roughflow.defaults.BOUNDARY_METHODS` (default
    :func:`default_boundary`). ``flow_tol``, ``flow_sigma_tol``: ``tol`` and ``sigma_tol`` of
    :func:`roughflow.flow.solve`. Bad input raises :class:`InputError` before any solve; a
    contact or flow solve that misses its tolerance raises ``ConvergenceError``. Pressures
    at which the analysed window holds no contact cell, or too few to resolve the contact,
    are logged as warnings (:data:`EMPTY_WINDOW_WARNING`, :func:`empty_window_pressures`;
    :data:`FEW_CELLS_WARNING`, :func:`few_cell_pressures`), and so are rows and sealing
    pressures at or above E* (:data:`LARGE_STRAIN_WARNING`, :func:`large_strain`). A first
    pressure below what the solver cell resolves (:func:`lowest_resolved_pressure`) is
    refused before any solve. ``modulus``: E* in Pa where known, for the messages only
    (their pressures then in Pa too).

    ``hardness`` (E*, as the pressures): every row's contact, and every solve of the
    sealing search, is solved with the pressure capped there (elastic-perfectly-plastic,
    ``contact.solve(..., hardness=)``; the thresholds carry it); each row's cell
    pressure must lie below it.
    """
    p = check_pressures(pressures)
    check_pressure_scale(p)
    if not isinstance(surface, Surface):
        raise InputError(f"surface must be a roughflow Surface, got {type(surface).__name__}")
    for name, v in (("contact_tol", contact_tol),
                    ("threshold_contact_tol", threshold_contact_tol)):
        check_contact_tol(v, name)
    for name, v in (("flow_tol", flow_tol), ("threshold_tol", threshold_tol)):
        require_positive(name, v)
    check_sigma_tol(flow_sigma_tol)
    if hardness is not None:
        hardness = check_hardness(hardness)
    if modulus is not None:
        require_positive("modulus", modulus)
    method = default_boundary(surface) if boundary is None else boundary
    emb = embed(surface, method)
    # the first solve's own check, made here: before the sealing search's checks and any solve
    check_resolved_load(emb.cell_pressure(p[0]), emb.surface.gbar, emb.surface.shape)
    if hardness is not None:
        require_below_hardness(
            emb.cell_pressure(p[-1]), hardness,
            load_text=(f"the nominal pressure {p[-1]:.4g} E* (on the solver cell of boundary "
                       f"{method!r}: {emb.cell_pressure(p[-1]):.4g} E*)"),
            hardness_text=f"the hardness {hardness:.4g} E*")
    gbar = surface.gbar
    if sealing:  # the sealing search's checks, before the curve's solves
        check_area_tol(threshold_tol, emb.shape)
        _sealing_options(emb, gbar=gbar, contact_tol=threshold_contact_tol, hardness=hardness)
    # a leak curve holds what a pressure ladder holds, on the embedded grid
    check_memory("ladder", emb.surface.heights.shape, what="a leak curve")
    curve = pressure_curve(emb, p, contact_tol=contact_tol, flow_tol=flow_tol,
                           flow_sigma_tol=flow_sigma_tol, threads=threads, hardness=hardness)
    plastic = curve.pop("plastic_fraction")
    _warn_sparse_rows(p, curve["area_fraction"], emb.shape, method, modulus)
    strained = large_strain(p)
    if strained.any():
        log.warning(LARGE_STRAIN_WARNING, "the nominal pressures",
                    _pressures_text(p[strained], modulus))
    thresholds = (sealing_search(emb, gbar=gbar, tol=threshold_tol,
                                 contact_tol=threshold_contact_tol, threads=threads,
                                 hardness=hardness)
                  if sealing else {})
    for ax, t in thresholds.items():
        if large_strain(t.p_hi):  # the seal closes at or above E*, if at all (NaN: no bracket)
            log.warning(LARGE_STRAIN_WARNING, f"the sealing pressure along {'xy'[ax]}",
                        _pressures_text([t.p_lo, t.p_hi], modulus, sep=" - "))
    # the sealing search's tolerances are recorded only where it ran
    searched = ({"threshold_tol": threshold_tol, "threshold_contact_tol": threshold_contact_tol}
                if sealing else {})
    return LeakCurve(
        pressure=p, **curve, thresholds=thresholds, boundary=method,
        rms_gradient=float(gbar), window_lx=emb.lx, window_ly=emb.ly,
        window_shape=emb.shape,
        settings={"contact_tol": contact_tol, "flow_tol": flow_tol,
                  **({} if flow_sigma_tol is None else {"flow_sigma_tol": flow_sigma_tol}),
                  **searched, "sealing_searched": int(sealing),
                  **({} if hardness is None else {"hardness": hardness})},
        plastic_fraction=plastic)


#: Logged by :func:`leak_curve` (arguments: the boundary method, the pressures: "... E*", or
#: with the modulus "... E* = ... Pa") where the analysed window holds no contact cell at
#: some pressures.
EMPTY_WINDOW_WARNING = (
    "the analysed window (boundary %r) holds no contact cell at the nominal pressures %s: "
    "all of the contact lies outside it (in the border that 'window' drops), so a_c = 0 "
    "there and the gap and leak rate are those of a window held open from outside, not a "
    "property of the seal; start the pressures higher, or use boundary 'mirror' (the whole "
    "scan analysed)")

#: Logged by :func:`leak_curve` (arguments: :data:`~roughflow.defaults.LEAK_MIN_CONTACT_CELLS`,
#: the pressures as for :data:`EMPTY_WINDOW_WARNING`, their contact cells, the window's cells
#: along x and y) where the analysed window holds contact at some pressures, but too few
#: cells of it to resolve it.
FEW_CELLS_WARNING = (
    "the analysed window holds fewer than %d contact cells at the nominal pressures %s "
    "(%s of its %d x %d cells): no contact spot spans more than a few grid cells, so a_c "
    "(over-counted by about 10 %% of itself or more) and the gap and leak rate those spots "
    "hold open are under-resolved; start the pressures higher, or check these rows on the "
    "scan interpolated to a finer grid")

#: Logged by :func:`leak_curve` (arguments: what, "the nominal pressures" or "the sealing
#: pressure along x", and its pressures as for :data:`EMPTY_WINDOW_WARNING`) where a row or
#: a sealing pressure is at or above E* (:func:`large_strain`).
LARGE_STRAIN_WARNING = (
    "%s at or above E* (%s): strains of order one, outside the linear-elastic contact model "
    "(small strains and slopes), whose results there are not the seal's; seals run far "
    "below E* (check the modulus, and the pressures' unit)")


def empty_window_rows(area_fraction: ArrayLike) -> np.ndarray:
    """Per row: whether the analysed window holds no contact cell (its ``area_fraction``, a
    count of the window's contact cells over its size, is exactly 0;
    :func:`empty_window_pressures` gives the reasons)."""
    return np.asarray(area_fraction) == 0


def empty_window_pressures(pressures: ArrayLike, area_fraction: ArrayLike) -> np.ndarray:
    """The nominal ``pressures`` at which the analysed window holds no contact cell: its
    ``area_fraction`` (a count of the window's contact cells over its size) is exactly 0.

    The criterion separates a result from a non-result: with one contact cell or more the
    window carries part of the load on its own asperities, and its a_c, gap and sigma are
    its own, if under-resolved below :data:`~roughflow.defaults.LEAK_MIN_CONTACT_CELLS`
    cells (:func:`few_cell_pressures`); with none, a_c is exactly 0 and the gap is set by
    asperities outside the window (with ``window``: in the dropped border or across the
    wrap-around seam), which says nothing about the seal. Only ``window`` can leave it
    empty: the whole cell (``periodic``) and the mirrored quadrant always carry contact
    under a positive load, and ``pad`` refuses a state with contact outside the scan."""
    p = np.asarray(pressures, dtype=np.float64)
    return p[empty_window_rows(area_fraction)]


def contact_cells(area_fraction: ArrayLike, window_shape: tuple[int, int]) -> np.ndarray:
    """The analysed window's contact cells per row: ``area_fraction`` (the window's contact
    mask averaged) times the cells of ``window_shape``, rounded off to whole cells."""
    cells = int(window_shape[0]) * int(window_shape[1])
    return np.rint(np.asarray(area_fraction, dtype=np.float64) * cells).astype(np.int64)


def few_cell_rows(area_fraction: ArrayLike, window_shape: tuple[int, int],
                  min_cells: int = LEAK_MIN_CONTACT_CELLS) -> np.ndarray:
    """Per row: whether the analysed window of ``window_shape`` holds contact (not
    :func:`empty_window_rows`, which have none) on fewer than ``min_cells`` cells
    (:func:`contact_cells`), too few to resolve it
    (:data:`~roughflow.defaults.LEAK_MIN_CONTACT_CELLS` gives the reasons)."""
    require_positive("min_cells", min_cells)
    return (~empty_window_rows(area_fraction)
            & (contact_cells(area_fraction, window_shape) < min_cells))


def few_cell_pressures(pressures: ArrayLike, area_fraction: ArrayLike,
                       window_shape: tuple[int, int],
                       min_cells: int = LEAK_MIN_CONTACT_CELLS) -> np.ndarray:
    """The nominal ``pressures`` of the rows :func:`few_cell_rows` flags: contact on fewer
    than ``min_cells`` cells of the analysed window, an under-resolved result."""
    p = np.asarray(pressures, dtype=np.float64)
    return p[few_cell_rows(area_fraction, window_shape, min_cells)]


def _warn_sparse_rows(pressures: np.ndarray, area_fraction: np.ndarray,
                      window_shape: tuple[int, int], boundary: str,
                      modulus: float | None = None) -> None:
    """Log :data:`EMPTY_WINDOW_WARNING` and :data:`FEW_CELLS_WARNING` for the rows they
    concern, if any (their pressures in Pa too where the ``modulus`` is known)."""
    empty = empty_window_pressures(pressures, area_fraction)
    if empty.size:
        log.warning(EMPTY_WINDOW_WARNING, boundary, _pressures_text(empty, modulus))
    few = few_cell_rows(area_fraction, window_shape)
    if few.any():
        cells = contact_cells(area_fraction, window_shape)[few]
        log.warning(FEW_CELLS_WARNING, LEAK_MIN_CONTACT_CELLS,
                    _pressures_text(pressures[few], modulus),
                    ", ".join(str(n) for n in cells), *window_shape)


def pressure_curve(emb: Embedding, pressures: np.ndarray, *, contact_tol: float = CONTACT_TOL,
                   flow_tol: float = FLOW_TOL, flow_sigma_tol: float | None = FLOW_SIGMA_TOL,
                   threads: int | None = None, hardness: float | None = None) -> dict:
    """Contact area, mean gap, percolation and conductances of the window of ``emb`` at
    each nominal pressure (increasing; warm-started solves): the :class:`LeakCurve` fields
    ``area_fraction``, ``mean_gap``, ``percolating``, ``sigma``, ``iterations``,
    ``residual``, ``flow_imbalance``, ``flow_sigma_error``, and ``plastic_fraction`` (of the
    window; None without a ``hardness``, the cap of the contact pressure in E*)."""
    n = len(pressures)
    area, gap, its, res = (np.zeros(n) for _ in range(4))
    plastic = None if hardness is None else np.zeros(n)
    spans = np.zeros((n, 2), dtype=bool)
    sigma, imbalance, sigma_error = (np.zeros((n, 2)) for _ in range(3))
    state: ContactResult | None = None
    flows = None  # the last pressure's, whose orderings the next solves reuse
    for i, pn in enumerate(pressures):
        state = solve(emb.surface, emb.cell_pressure(pn), tol=contact_tol, init=state,
                      threads=threads, hardness=hardness)
        seen = emb.observe(state)
        area[i], gap[i] = seen.area_fraction, seen.mean_gap
        if plastic is not None:
            plastic[i] = float(state.plastic[emb.window].mean())
        its[i], res[i] = state.iterations, state.residual
        flows = flow.flow_both_axes(seen.gap, ~seen.contact, lx=emb.lx, ly=emb.ly,
                                    periodic=emb.periodic, previous=flows, tol=flow_tol,
                                    sigma_tol=flow_sigma_tol)
        for ax, f in enumerate(flows):
            spans[i, ax], sigma[i, ax] = f.percolating, f.sigma
            if f.result is not None:
                imbalance[i, ax] = f.result.flux_imbalance
                sigma_error[i, ax] = f.result.sigma_error
        log.info("p = %.4g E*: a_c = %.4f, percolating x %d y %d, sigma = %.3e, %.3e", pn,
                 area[i], spans[i, 0], spans[i, 1], sigma[i, 0], sigma[i, 1])
    return {"area_fraction": area, "mean_gap": gap, "percolating": spans, "sigma": sigma,
            "iterations": its.astype(np.int64), "residual": res, "flow_imbalance": imbalance,
            "flow_sigma_error": sigma_error, "plastic_fraction": plastic}
