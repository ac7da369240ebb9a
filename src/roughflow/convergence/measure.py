"""The measurements of the accuracy study: the resolution and the tolerance phases.

Each appends one JSON record per measurement to its record log (:mod:`.records`) and hands
it to ``on_record`` as well (the command line prints it); a run that completes writes the
whole log as a netCDF dataset beside it (:mod:`.dataset`), and a run removes that dataset
before any work, so that one is there only where the last run completed. Wall times are
taken after :func:`warm_up`, and FFT plans are made before a grid size is timed.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from roughflow import accuracy, contact, fft, flow
from roughflow.errors import ConvergenceError, InputError
from roughflow.provenance import Provenance
from roughflow.search import LoadSearch, SearchOptions, threshold
from roughflow.search import warm_up as search_warm_up
from roughflow.surface import Surface, SurfaceSpec, generate

from .dataset import write_records_dataset
from .load_path import shifted_sigma
from .options import TARGETS, ResolutionOptions, ToleranceOptions, study_specs
from .records import (
    RecordLog,
    dataset_file,
    load_records,
    resolution_file,
    tolerance_file,
)

OnRecord = Callable[[dict], None]


def warm_up() -> None:
    """Keep one-off costs out of the timings: numba compilation of the contact and search
    kernels (:func:`roughflow.search.warm_up`) and the flow solvers' imports (one small
    untimed solve)."""
    search_warm_up()
    s = generate(SurfaceSpec.from_sweep(points_per_lambda_s=2, seed=0))
    flow.solve(contact.solve(s, 0.1).gap, 0, lx=s.lx, ly=s.ly)


def _plan(shape: tuple[int, int]) -> None:
    """FFTW plans are made per shape at first use: make them before a size is timed (the
    solvers use the float32 plan as well)."""
    fft.plan(shape)
    fft.plan(shape, single=True)


def _faces(contact_mask: np.ndarray) -> dict:
    """Contact/non-contact faces normal to x and to y per cell (pixel counts)."""
    fx, fy = accuracy.contact_faces(contact_mask)
    n = contact_mask.size
    return {"tx": fx / n, "ty": fy / n}


def sampled_surface(finest: Surface, ppl: int, ppl_max: int) -> Surface:
    """``finest`` (the seed's surface generated at ``ppl_max``, :func:`~.options.study_specs`)
    sampled down to ``ppl`` points per lambda_s: the same physical surface on the coarser
    grid (for gamma != 1 the grid has ``ppl`` points per shortest wavelength along each axis,
    so both axes are sampled by the same factor)."""
    k = ppl_max // ppl
    if k * ppl != ppl_max or finest.shape[0] % k or finest.shape[1] % k:
        raise InputError(f"grid {finest.shape} at ppl {ppl_max} cannot be sampled down to "
                         f"ppl {ppl}")
    return Surface.from_array(np.ascontiguousarray(finest.heights[::k, ::k]),
                              lx=finest.lx, ly=finest.ly)


@dataclass(frozen=True)
class AreaHit:
    """The contact solves of a load search onto a target area: its ``first`` solve (at the
    contact law's load, the same at every resolution), the ``last`` one (the area within
    tolerance) and how many it took."""

    first: contact.ContactResult
    last: contact.ContactResult
    n_solves: int


def hit_area(surf: Surface, target: float, *, tol_a: float, ctol: float,
             init: contact.ContactResult | None = None) -> AreaHit:
    """Contact solves until |a_c - target| <= tol_a (the shared load search, whose first
    load is the contact law's)."""
    solves = []

    def solve(p, warm):
        solves.append(contact.solve(surf, p, tol=ctol, init=init if warm is None else warm))
        return solves[-1]

    found = LoadSearch(solve, contact.ContactLaw()).solve_for(target, tol_a, max_solves=8)
    return AreaHit(solves[0], found.result, found.solves)


def threshold_record(surf: Surface, *, tol: float, contact_tol: float,
                     on_unbracketed: str = "raise") -> dict:
    """a_c* along x and y (raw and as the search corrects it), and one contact solve at
    each axis' bracket midpoint: the contact-line faces normal to x and to y per cell
    (``tx_{ax}``, ``ty_{ax}``) at that axis' threshold, from which any weighting of the
    perimeter term can be evaluated afterwards."""
    t0 = time.perf_counter()
    th = threshold(surf, axis=None, tol=tol, options=SearchOptions(
        contact_tol=contact_tol, on_unbracketed=on_unbracketed))
    rec = dict(time=time.perf_counter() - t0, n_solves=th[0].n_solves)
    t0 = time.perf_counter()
    rm = None
    for ax in (0, 1):
        rec[f"a_star_{ax}"] = th[ax].a_c_star
        rec[f"a_star_corrected_{ax}"] = th[ax].a_c_star_corrected
        rec[f"a_lo_{ax}"], rec[f"a_hi_{ax}"] = th[ax].a_lo, th[ax].a_hi
        if not th[ax].bracketed:
            rec.update({f"{k}_{ax}": float("nan") for k in ("a_mid", "perim", "tx", "ty")})
            continue
        rm = contact.solve(surf, 0.5 * (th[ax].p_lo + th[ax].p_hi), tol=contact_tol, init=rm)
        rec[f"a_mid_{ax}"] = rm.area_fraction
        rec[f"perim_{ax}"] = accuracy.perimeter_term(rm.contact)
        rec.update({f"{k}_{ax}": v for k, v in _faces(rm.contact).items()})
    rec["time_mid"] = (time.perf_counter() - t0) / 2
    rec["perim_mid"] = 0.5 * (rec["perim_0"] + rec["perim_1"])
    return rec


def _fixed_loads(surf: Surface, base: dict, targets: tuple[float, ...], contact_tol: float,
                 emit: OnRecord) -> None:
    """Contact solves at the contact law's loads for ``targets`` (the same pressures at every
    resolution): the points that fit the perimeter constant."""
    init = None
    for target in targets:
        p = contact.ContactLaw().control(target)
        t0 = time.perf_counter()
        r = contact.solve(surf, p, tol=contact_tol, init=init)
        init = r
        emit(dict(
            kind="fixed", **base, target=target, p_fixed=p,
            a_fixed=r.area_fraction, gap_fixed=r.mean_gap,
            perim_fixed=accuracy.perimeter_term(r.contact),
            **{f"{k}_fixed": v for k, v in _faces(r.contact).items()},
            contact_tol=contact_tol, time_contact=time.perf_counter() - t0))


def _sigma_targets(surf: Surface, base: dict, targets: tuple[float, ...],
                   opts: ResolutionOptions, emit: OnRecord) -> None:
    """sigma_x at each of ``targets`` (the load search, then one flow solve), with the
    search's first solve at the contact law's load."""
    init = None
    for target in targets:
        t0 = time.perf_counter()
        hit = hit_area(surf, target, tol_a=opts.area_tol, ctol=opts.contact_tol, init=init)
        t_c = time.perf_counter() - t0
        first, r = hit.first, hit.last
        init = r
        t0 = time.perf_counter()
        fr = flow.solve(r.gap, 0, lx=surf.lx, ly=surf.ly)
        t_f = time.perf_counter() - t0
        a = r.area_fraction
        sig = fr.sigma
        emit(dict(
            kind="sigma", **base, target=target,
            p_fixed=first.pressure, a_fixed=first.area_fraction,
            gap_fixed=first.mean_gap,
            perim_fixed=accuracy.perimeter_term(first.contact),
            **{f"{k}_fixed": v for k, v in _faces(first.contact).items()},
            a=a, perim=accuracy.perimeter_term(r.contact),
            sigma_raw=sig, sigma=shifted_sigma(sig, a, target), mean_gap=r.mean_gap,
            n_contact_solves=hit.n_solves, time_contact=t_c, time_flow=t_f,
            flow_residual=fr.residual, flux_imbalance=fr.flux_imbalance,
            contact_tol=opts.contact_tol, area_tol=opts.area_tol,
        ))


def _check_fits(spec: SurfaceSpec, task: str) -> None:
    """Refuse a grid whose solves would not fit in memory before any of the study runs (the
    finest grid comes last, after every coarser one)."""
    from roughflow.resources import check_memory

    check_memory(task, (spec.nx, spec.ny), what="the accuracy study's largest grid")


def _check_same_run(path: Path, rec: dict, expected: dict) -> None:
    """Refuse to resume into ``path`` when its record ``rec`` was made with other settings
    than ``expected`` (field -> value; a field the record lacks is not compared): the report
    would mix two runs."""
    for field, value in expected.items():
        if field in rec and rec[field] != value:
            # where the sweep's grids do not nest, the study's grids depend on the whole
            # set of resolutions (options.study_specs)
            grids = (" (the grids depend on the whole set of --ppl where the sweep's own "
                     "do not nest: measure every resolution in one run)"
                     if field in ("n", "ny") else "")
            raise InputError(
                f"{path} holds records of another run: {field} {rec[field]!r} there, "
                f"{value!r} here (record {rec['kind']}, seed {rec['seed']}){grids}: give "
                "another --out, or remove the file to start afresh")


def _start(path: Path) -> None:
    """Remove the dataset of the record log ``path`` once a run passed its checks, before it
    works: it is written again when the run completes, and a run that fails leaves none (not
    an earlier run's, which would look complete). A refused run leaves the log and its
    dataset as they were."""
    dataset_file(path).unlink(missing_ok=True)


def _emitter(log: RecordLog, on_record: OnRecord | None) -> OnRecord:
    def emit(rec: dict) -> None:
        log.append(rec)
        if on_record is not None:
            on_record(rec)
    return emit


def measure_resolution(out: str | os.PathLike, opts: ResolutionOptions, *,
                       on_record: OnRecord | None = None, warm: bool = True,
                       provenance: Provenance | None = None) -> Path:
    """The resolution study into the record log :func:`~.records.resolution_file` under
    ``out``; returns that log. Records already in it are not computed again (a run can be
    resumed); records of other settings (another L/lambda_r, grid or tolerance) are refused
    before any work. At the end the whole log is written as a dataset beside it
    (:func:`~.dataset.write_records_dataset`, with ``provenance``). ``warm``:
    :func:`warm_up` first (False where the caller has)."""
    path = resolution_file(out, opts.gamma)
    grids = study_specs(opts.ppl, gamma=opts.gamma, l_over_lambda_r=opts.l_over_lambda_r)
    _check_fits(grids[max(opts.ppl)], "ladder" if opts.with_sigma else "threshold")
    with RecordLog(path) as log:
        _resolution_run(log, opts, grids, on_record, warm)
        log.require_current()
        write_records_dataset(path, study="resolution", provenance=provenance)
    return path


def _resolution_run(log: RecordLog, opts: ResolutionOptions, grids: dict[int, SurfaceSpec],
                    on_record: OnRecord | None, warm: bool) -> None:
    """:func:`measure_resolution`'s checks and measurements, into ``log``."""
    path = log.path
    ppl_max = max(opts.ppl)
    records = load_records(path)
    for r in records:
        expected = dict(gamma=opts.gamma, l_over_lambda_r=opts.l_over_lambda_r)
        if r["ppl"] in grids:
            expected.update(n=grids[r["ppl"]].nx, ny=grids[r["ppl"]].ny)
        if r["kind"] == "threshold":
            expected.update(bisect_tol=opts.bisect_tol, contact_tol=opts.threshold_contact_tol)
        else:
            expected.update(contact_tol=opts.contact_tol, area_tol=opts.area_tol)
        _check_same_run(path, r, expected)
    _start(path)
    done = {(r["kind"], r["seed"], r["ppl"], r.get("target")) for r in records}
    todo = []
    for seed, ppl in ((s, p) for s in opts.seeds for p in sorted(opts.ppl)):
        loads = TARGETS if opts.with_sigma else opts.fixed_targets
        kind = "sigma" if opts.with_sigma else "fixed"
        missing = tuple(t for t in loads if (kind, seed, ppl, t) not in done)
        has_threshold = ("threshold", seed, ppl, None) in done
        if not has_threshold or missing:
            todo.append((seed, ppl, has_threshold, missing))
    if warm and todo:
        warm_up()
    emit = _emitter(log, on_record)
    finest: dict[int, Surface] = {}
    # seed by seed (every resolution of a seed before the next seed): an interrupted run
    # leaves complete seeds, and only one finest surface is held in memory
    for seed, ppl, has_threshold, missing in todo:
        if seed not in finest:
            finest.clear()
            finest[seed] = generate(replace(grids[ppl_max], seed=seed))
        surf = sampled_surface(finest[seed], ppl, ppl_max)
        _plan(surf.shape)
        base = dict(seed=seed, ppl=ppl, n=surf.shape[0], ny=surf.shape[1],
                    gamma=opts.gamma, l_over_lambda_r=opts.l_over_lambda_r,
                    dx=surf.dx, dy=surf.dy)
        if not has_threshold:
            emit(dict(kind="threshold", **base, bisect_tol=opts.bisect_tol,
                      contact_tol=opts.threshold_contact_tol,
                      **threshold_record(surf, tol=opts.bisect_tol,
                                         contact_tol=opts.threshold_contact_tol)))
        if opts.with_sigma:
            _sigma_targets(surf, base, missing, opts, emit)
        else:
            _fixed_loads(surf, base, missing, opts.contact_tol, emit)


def _tolerance_key(rec: dict) -> tuple:
    """What a tolerance record measured: its kind (a failed search counts as its kind), seed
    and the tolerance (and target) it varied."""
    kind = rec["kind"].removesuffix("_failed")
    if kind == "contact_tol":
        return kind, rec["seed"], rec["target"], rec["contact_tol"]
    return kind, rec["seed"], rec["contact_tol" if kind == "threshold_contact_tol"
                                  else "bisect_tol"]


def _contact_tolerances(surf: Surface, seed: int, opts: ToleranceOptions, done: set[tuple],
                        emit: OnRecord) -> None:
    """Contact tolerance at fixed load (a_c ~ 0.2 and ~ 0.35), cold solves."""
    for target in TARGETS:
        p = contact.ContactLaw().control(target)
        for ctol in opts.contact_tols:
            if ("contact_tol", seed, target, ctol) in done:
                continue
            t0 = time.perf_counter()
            r = contact.solve(surf, p, tol=ctol)
            t_c = time.perf_counter() - t0
            t0 = time.perf_counter()
            sig = flow.solve(r.gap, 0, lx=surf.lx, ly=surf.ly).sigma
            t_f = time.perf_counter() - t0
            emit(dict(kind="contact_tol", seed=seed, ppl=opts.ppl, target=target,
                      p=p, contact_tol=ctol, a=r.area_fraction,
                      mean_gap=r.mean_gap, sigma=sig, iterations=r.iterations,
                      time_contact=t_c, time_flow=t_f))


def _threshold_contact_tolerances(surf: Surface, seed: int, opts: ToleranceOptions,
                                  done: set[tuple], emit: OnRecord) -> None:
    """Contact tolerance inside the threshold bisection (a loose one makes a(p) jump: a
    search that fails is recorded as such)."""
    for ctol in opts.threshold_contact_tols:
        if ("threshold_contact_tol", seed, ctol) in done:
            continue
        t0 = time.perf_counter()
        try:
            th = threshold(surf, axis=None, tol=opts.threshold_bisect_tol,
                           options=SearchOptions(contact_tol=ctol, max_solves=80))
        except ConvergenceError as e:
            emit(dict(kind="threshold_contact_tol_failed", seed=seed, ppl=opts.ppl,
                      contact_tol=ctol, bisect_tol=opts.threshold_bisect_tol,
                      error=str(e)))
            continue
        emit(dict(kind="threshold_contact_tol", seed=seed, ppl=opts.ppl,
                  contact_tol=ctol, bisect_tol=opts.threshold_bisect_tol,
                  time=time.perf_counter() - t0, n_solves=th[0].n_solves,
                  a_star_0=th[0].a_c_star, a_star_1=th[1].a_c_star))


def _bisection_tolerances(surf: Surface, seed: int, opts: ToleranceOptions, done: set[tuple],
                          emit: OnRecord) -> None:
    """a_c* against the bisection tolerance."""
    for btol in opts.bisect_tols:
        if ("bisect_tol", seed, btol) in done:
            continue
        t0 = time.perf_counter()
        try:
            th = threshold(surf, axis=None, tol=btol, options=SearchOptions(
                max_solves=80, contact_tol=opts.threshold_contact_tol))
        except ConvergenceError as e:
            emit(dict(kind="bisect_tol_failed", seed=seed, ppl=opts.ppl,
                      bisect_tol=btol, contact_tol=opts.threshold_contact_tol, error=str(e)))
            continue
        emit(dict(kind="bisect_tol", seed=seed, ppl=opts.ppl, bisect_tol=btol,
                  contact_tol=opts.threshold_contact_tol,
                  time=time.perf_counter() - t0, n_solves=th[0].n_solves,
                  a_star_0=th[0].a_c_star, a_star_1=th[1].a_c_star,
                  width_0=th[0].width, width_1=th[1].width))


def measure_tolerances(out: str | os.PathLike, opts: ToleranceOptions, *,
                       on_record: OnRecord | None = None, warm: bool = True,
                       provenance: Provenance | None = None) -> Path:
    """The tolerance study into the record log :func:`~.records.tolerance_file` under
    ``out``; returns that log. Measurements already in it are not made again (a run can be
    resumed, or extended by seeds and tolerances); records of other settings (resolution,
    the fixed tolerance of a study) are refused before any work. At the end the whole log
    is written as a dataset beside it (:func:`~.dataset.write_records_dataset`, with
    ``provenance``). ``warm``: :func:`warm_up` first (False where the caller has)."""
    path = tolerance_file(out)
    _check_fits(SurfaceSpec.from_sweep(points_per_lambda_s=opts.ppl), "ladder")
    with RecordLog(path) as log:
        _tolerance_run(log, opts, on_record, warm)
        log.require_current()
        write_records_dataset(path, study="tolerance", provenance=provenance)
    return path


def _tolerance_run(log: RecordLog, opts: ToleranceOptions, on_record: OnRecord | None,
                   warm: bool) -> None:
    """:func:`measure_tolerances`' checks and measurements, into ``log``."""
    path = log.path
    records = load_records(path)
    for r in records:
        expected: dict = dict(ppl=opts.ppl)
        if r["kind"].startswith("threshold_contact_tol"):
            expected.update(bisect_tol=opts.threshold_bisect_tol)
        elif r["kind"].startswith("bisect_tol"):
            expected.update(contact_tol=opts.threshold_contact_tol)
        _check_same_run(path, r, expected)
    _start(path)
    done = {_tolerance_key(r) for r in records}
    wanted = {("contact_tol", s, t, c) for s in opts.seeds for t in TARGETS
              for c in opts.contact_tols}
    wanted |= {("threshold_contact_tol", s, c) for s in opts.seeds
               for c in opts.threshold_contact_tols}
    wanted |= {("bisect_tol", s, b) for s in opts.seeds for b in opts.bisect_tols}
    if warm and wanted - done:
        warm_up()
    emit = _emitter(log, on_record)
    for seed in opts.seeds:
        if not any(key[1] == seed for key in wanted - done):
            continue
        surf = generate(SurfaceSpec.from_sweep(points_per_lambda_s=opts.ppl, seed=seed))
        _plan(surf.shape)
        _contact_tolerances(surf, seed, opts, done, emit)
        _threshold_contact_tolerances(surf, seed, opts, done, emit)
        _bisection_tolerances(surf, seed, opts, done, emit)
