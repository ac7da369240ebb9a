"""Convergence studies: numerical error against wall time for a_c* and sigma.

Phases (each appends JSON lines under ``--out``; ``report`` turns them into tables + PNGs):

- ``resolution``: per seed, one surface generated at the finest resolution and sampled at
  every coarser one (the spectrum is band-limited below q_s, so ``h[::k, ::k]`` is the same
  continuum surface on a coarser grid: a resolution study on one physical surface).
  For each points_per_lambda_s: a_c* along x and y (``search.threshold``), one extra
  contact solve at the threshold for the contact-line length, and sigma_x at a_c = 0.2 and
  0.35 (pressure found by the shared load search, then one flow solve). The first solve of
  each target is at a fixed pressure (the same at every resolution): those points fit the
  perimeter constant c of :func:`roughflow.accuracy.perimeter_corrected_area`.
- ``tol``: at the default resolution, a_c*, a_c, mean gap and sigma against the contact
  solver tolerance, and a_c* against the bisection tolerance.
- ``report``: tables (markdown + CSV) and error-versus-time plots under ``--out``.

Reproduce (about 2 minutes; 72 s on 2 cores on 2026-12-06)::

    ROUGHFLOW_FFT_THREADS=1 python benchmarks/convergence.py resolution --seeds 0 1 2
    ROUGHFLOW_FFT_THREADS=1 python benchmarks/convergence.py tol --seeds 0 1 2
    python benchmarks/convergence.py report
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

os.environ.setdefault("ROUGHFLOW_FFT_THREADS", "1")

from roughflow import accuracy, contact, fft, flow  # noqa: E402
from roughflow.defaults import A_C_STAR_PAPER  # noqa: E402
from roughflow.errors import ConvergenceError  # noqa: E402
from roughflow.search import LoadSearch, SearchOptions, threshold, warm_up  # noqa: E402
from roughflow.surface import Surface, SurfaceSpec, generate  # noqa: E402
from roughflow.theory.closed_form import EXPONENTS  # noqa: E402

TARGETS = (0.2, 0.35)
#: d ln sigma / d a_c ~ -beta / (a_c* - a_c), the elastic exponent of Eq. 16 (docs/physics.md
#: Sect. 5), with the seed's own reference a_c*(x) (the paper's value where the run has no
#: thresholds): moves sigma along the load path onto the perimeter-corrected target
BETA, A_STAR = EXPONENTS["elastic"], A_C_STAR_PAPER


def _append(path: Path, rec: dict) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("a") as f:
        f.write(json.dumps(rec) + "\n")
    print(json.dumps(rec), flush=True)


def _surface(seed: int, ppl: int, ppl_max: int, cache: dict, gamma: float = 1.0,
             l_over_lambda_r: float | None = None) -> Surface:
    """The seed's surface generated at ``ppl_max`` and sampled down to ``ppl`` (same physical
    surface at every resolution; for gamma != 1 the grid has ``ppl`` points per shortest
    wavelength along each axis, so both axes are sampled by the same factor)."""
    if seed not in cache:
        spec = SurfaceSpec.from_sweep(gamma=gamma, l_over_lambda_r=l_over_lambda_r,
                                      points_per_lambda_s=ppl_max, seed=seed)
        cache[seed] = generate(spec)
    s = cache[seed]
    k = ppl_max // ppl
    if k * ppl != ppl_max:
        raise SystemExit(f"points_per_lambda_s {ppl} does not divide {ppl_max}")
    coarse = SurfaceSpec.from_sweep(gamma=gamma, l_over_lambda_r=l_over_lambda_r,
                                    points_per_lambda_s=ppl, seed=seed)
    if (coarse.nx * k, coarse.ny * k) != s.shape:  # fft_friendly rounding broke the ratio
        raise SystemExit(f"grid {s.shape} at ppl {ppl_max} is not {k} x the grid "
                         f"({coarse.nx}, {coarse.ny}) at ppl {ppl}")
    return Surface.from_array(np.ascontiguousarray(s.heights[::k, ::k]), lx=s.lx, ly=s.ly)


def _warm_up() -> None:
    """Keep one-off costs out of the timings: numba compilation of the contact and search
    kernels (search.warm_up) and the flow solvers' imports (one small untimed solve)."""
    warm_up()
    s = generate(SurfaceSpec.from_sweep(points_per_lambda_s=2, seed=0))
    flow.solve(contact.solve(s, 0.1).gap, 0, lx=s.lx, ly=s.ly)


def _plan(shape) -> None:
    """FFTW plans are made per shape at first use: make them before a size is timed (the
    solvers use the float32 plan as well)."""
    fft.plan(shape)
    fft.plan(shape, single=True)


def _faces(contact_mask) -> dict:
    """Contact/non-contact faces normal to x and to y per cell (pixel counts)."""
    fx, fy = accuracy.contact_faces(contact_mask)
    n = contact_mask.size
    return {"tx": fx / n, "ty": fy / n}


def _hit_area(surf: Surface, target: float, *, tol_a: float, ctol: float, init=None):
    """Contact solves until |a_c - target| <= tol_a (the shared load search, whose first load
    is the contact law's, the same at every resolution); returns (first, last, n_solves)."""
    solves = []

    def solve(p, warm):
        solves.append(contact.solve(surf, p, tol=ctol, init=init if warm is None else warm))
        return solves[-1]

    found = LoadSearch(solve, contact.ContactLaw()).solve_for(target, tol_a, max_solves=8)
    return solves[0], found.result, found.solves


def resolution_file(out: str | Path, gamma: float) -> Path:
    """JSON-lines file of the resolution phase for one gamma (the isotropic name is kept)."""
    name = ("convergence_resolution.jsonl" if gamma == 1.0
            else f"convergence_resolution_g{gamma:g}.jsonl")
    return Path(out) / name


def threshold_record(surf: Surface, *, tol: float, contact_tol: float,
                     on_unbracketed: str = "raise") -> dict:
    """a_c* along x and y (raw and as the search corrects it), and one contact solve at
    each axis' bracket midpoint: the contact-line faces normal to x and to y per cell
    (``tx_{ax}``, ``ty_{ax}``) at that axis' threshold, from which any weighting of the
    perimeter term can be evaluated afterwards. Also used by benchmarks/finite_size.py."""
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


def phase_resolution(args) -> None:
    out = resolution_file(args.out, args.gamma)
    with_sigma = args.gamma == 1.0 if args.sigma is None else args.sigma
    ppl_max = max(args.ppl)
    cache: dict = {}
    # records already in the file are not computed again (runs can be resumed)
    done = {(r["kind"], r["seed"], r["ppl"], r.get("target")) for r in _load(out)}
    # seed by seed (every resolution of a seed before the next seed): an interrupted run
    # leaves complete seeds, and only one finest surface is held in memory
    for seed, ppl in ((s, p) for s in args.seeds for p in sorted(args.ppl)):
        todo_fixed = [t for t in args.fixed_targets if ("fixed", seed, ppl, t) not in done]
        has_threshold = ("threshold", seed, ppl, None) in done
        if has_threshold and (with_sigma or not todo_fixed):
            continue
        if seed not in cache:
            cache.clear()
        surf = _surface(seed, ppl, ppl_max, cache, args.gamma, args.l_over_lambda_r)
        _plan(surf.shape)
        base = dict(seed=seed, ppl=ppl, n=surf.shape[0], ny=surf.shape[1],
                    gamma=args.gamma, l_over_lambda_r=args.l_over_lambda_r,
                    dx=surf.dx, dy=surf.dy)
        if not has_threshold:
            _append(out, dict(kind="threshold", **base, bisect_tol=args.bisect_tol,
                              contact_tol=args.threshold_contact_tol,
                              **threshold_record(surf, tol=args.bisect_tol,
                                                 contact_tol=args.threshold_contact_tol)))
        init = None
        if not with_sigma:
            # fixed loads only (the same pressures at every resolution): the points that
            # fit the perimeter constant
            for target in todo_fixed:
                p = contact.ContactLaw().control(target)
                t0 = time.perf_counter()
                r = contact.solve(surf, p, tol=args.contact_tol, init=init)
                init = r
                _append(out, dict(
                    kind="fixed", **base, target=target, p_fixed=p,
                    a_fixed=r.area_fraction, gap_fixed=r.mean_gap,
                    perim_fixed=accuracy.perimeter_term(r.contact),
                    **{f"{k}_fixed": v for k, v in _faces(r.contact).items()},
                    contact_tol=args.contact_tol, time_contact=time.perf_counter() - t0))
            continue
        for target in TARGETS:
            t0 = time.perf_counter()
            first, r, ns = _hit_area(surf, target, tol_a=args.area_tol,
                                     ctol=args.contact_tol, init=init)
            t_c = time.perf_counter() - t0
            init = r
            t0 = time.perf_counter()
            fr = flow.solve(r.gap, 0, lx=surf.lx, ly=surf.ly)
            t_f = time.perf_counter() - t0
            a = r.area_fraction
            sig = fr.sigma
            ln_sig_t = (math.log(sig) - BETA / (A_STAR - a) * (target - a)
                        if sig > 0 else float("nan"))
            _append(out, dict(
                kind="sigma", **base, target=target,
                p_fixed=first.pressure, a_fixed=first.area_fraction,
                gap_fixed=first.mean_gap,
                perim_fixed=accuracy.perimeter_term(first.contact),
                **{f"{k}_fixed": v for k, v in _faces(first.contact).items()},
                a=a, perim=accuracy.perimeter_term(r.contact),
                sigma_raw=sig, sigma=math.exp(ln_sig_t), mean_gap=r.mean_gap,
                n_contact_solves=ns, time_contact=t_c, time_flow=t_f,
                flow_residual=fr.residual, flux_imbalance=fr.flux_imbalance,
                contact_tol=args.contact_tol,
            ))


def phase_tol(args) -> None:
    out = Path(args.out) / "convergence_tol.jsonl"
    ppl = args.tol_ppl
    for seed in args.seeds:
        spec = SurfaceSpec.from_sweep(points_per_lambda_s=ppl, seed=seed)
        surf = generate(spec)
        _plan(surf.shape)
        # contact tolerance at fixed load (a_c ~ 0.35 and ~ 0.2), cold solves
        for target in TARGETS:
            p = contact.ContactLaw().control(target)
            for ctol in args.contact_tols:
                t0 = time.perf_counter()
                r = contact.solve(surf, p, tol=ctol)
                t_c = time.perf_counter() - t0
                t0 = time.perf_counter()
                sig = flow.solve(r.gap, 0, lx=surf.lx, ly=surf.ly).sigma
                t_f = time.perf_counter() - t0
                _append(out, dict(kind="contact_tol", seed=seed, ppl=ppl, target=target,
                                  p=p, contact_tol=ctol, a=r.area_fraction,
                                  mean_gap=r.mean_gap, sigma=sig, iterations=r.iterations,
                                  time_contact=t_c, time_flow=t_f))
        # contact tolerance inside the threshold bisection
        for ctol in args.threshold_contact_tols:
            t0 = time.perf_counter()
            try:
                th = threshold(surf, axis=None, tol=args.threshold_bisect_tol,
                               options=SearchOptions(contact_tol=ctol, max_solves=80))
            except ConvergenceError as e:  # a loose contact tol makes a(p) jump
                _append(out, dict(kind="threshold_contact_tol_failed", seed=seed, ppl=ppl,
                                  contact_tol=ctol, bisect_tol=args.threshold_bisect_tol,
                                  error=str(e)))
                continue
            _append(out, dict(kind="threshold_contact_tol", seed=seed, ppl=ppl,
                              contact_tol=ctol, bisect_tol=args.threshold_bisect_tol,
                              time=time.perf_counter() - t0, n_solves=th[0].n_solves,
                              a_star_0=th[0].a_c_star, a_star_1=th[1].a_c_star))
        for btol in args.bisect_tols:
            t0 = time.perf_counter()
            try:
                th = threshold(surf, axis=None, tol=btol, options=SearchOptions(
                    max_solves=80, contact_tol=args.threshold_contact_tol))
            except ConvergenceError as e:
                _append(out, dict(kind="bisect_tol_failed", seed=seed, ppl=ppl,
                                  bisect_tol=btol, error=str(e)))
                continue
            _append(out, dict(kind="bisect_tol", seed=seed, ppl=ppl, bisect_tol=btol,
                              contact_tol=args.threshold_contact_tol,
                              time=time.perf_counter() - t0, n_solves=th[0].n_solves,
                              a_star_0=th[0].a_c_star, a_star_1=th[1].a_c_star,
                              width_0=th[0].width, width_1=th[1].width))


# ---------------------------------------------------------------------------------------
# report
# ---------------------------------------------------------------------------------------

def _load(path: Path) -> list[dict]:
    if not path.exists():
        return []
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def _md_table(header: list[str], rows: list[list]) -> str:
    def fmt(v):
        if isinstance(v, float):
            return f"{v:.4g}"
        return str(v)
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(fmt(v) for v in r) + " |" for r in rows]
    return "\n".join(lines)


def _write(outdir: Path, stem: str, md: list[str], csv_rows: list[str], fig, png: str) -> None:
    """Save the figure, the markdown tables and the CSV of one report; print the tables."""
    import matplotlib.pyplot as plt

    fig.tight_layout()
    fig.savefig(outdir / png, dpi=120)
    plt.close(fig)
    (outdir / f"{stem}.md").write_text("\n".join(md))
    (outdir / f"{stem}.csv").write_text("\n".join(csv_rows) + "\n")
    print("\n".join(md))


#: note under every table whose reference is the first-order Richardson extrapolation
EXTRAP_NOTE = ("Rows marked (extrapolation) are the two grids the reference is extrapolated "
               "from: their errors are -r/(r-1) and -1/(r-1) times the difference of the two "
               "grids (r = spacing ratio), fixed by construction, not measured.")


#: the same for the plots: their points at the reference's own grids are labelled "ref"
PLOT_EXTRAP_NOTE = "ref: a grid of the reference (its error is no measurement)"


def _plot_label(p: int, fine, variant: str) -> str:
    """Label of a plotted point: its points per lambda_s, "ref" on the reference's grids."""
    return f"{p} ref" if p in fine and variant != "richardson" else str(p)


def _ppl(p: int, fine) -> int | str:
    """ppl cell of a table: the reference's own grids are marked (their error is no
    measurement)."""
    return f"{p} (extrapolation)" if p in fine else p


def _fit_c(sig: list[dict], ppls: list[int], exclude_seed=None) -> float:
    pts = [r for r in sig if r["ppl"] in ppls and r["seed"] != exclude_seed]
    if len({r["ppl"] for r in pts}) < 2:
        return float("nan")
    fit = accuracy.fit_perimeter_constant(
        [(r["seed"], r["target"]) for r in pts], [r["a_fixed"] for r in pts],
        [r["perim_fixed"] for r in pts])
    return fit.c


def _sigma_at_corrected_area(q: dict, target: float, c: float, a_star: float = A_STAR) -> float:
    """ln sigma at the state whose perimeter-corrected area equals ``target``."""
    a, a0 = q["a"], q["a_fixed"]
    slope = -BETA / (a_star - a)
    if abs(a - a0) > 1e-4:
        slope += 3 * (math.log(q["mean_gap"]) - math.log(q["gap_fixed"])) / (a - a0)
    a_cor = a - c * q["perim"]
    return math.log(q["sigma_raw"]) + slope * (target - a_cor)


def report(args) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    outdir = Path(args.out)
    res = _load(outdir / "convergence_resolution.jsonl")
    tol = _load(outdir / "convergence_tol.jsonl")
    md: list[str] = ["# Convergence study (generated by benchmarks/convergence.py report)\n"]
    csv_rows: list[str] = ["quantity,variant,ppl,seed,value,reference,error,time_s"]
    thr = [r for r in res if r["kind"] == "threshold"]
    sig = [r for r in res if r["kind"] == "sigma"]
    fixed = [r for r in res if r["kind"] in ("sigma", "fixed")]  # fixed-load solves
    ppls = sorted({r["ppl"] for r in res})
    seeds = sorted({r["seed"] for r in res})
    # keep only seeds with every resolution
    seeds = [s for s in seeds if all(any(r["seed"] == s and r["ppl"] == p for r in thr)
                                     for p in ppls)]
    fit_ppls = [p for p in ppls if p >= args.fit_min_ppl]
    c_all = _fit_c(fixed, fit_ppls) if fixed else float("nan")
    fit = None
    if fixed and len(fit_ppls) >= 2:
        pts = [r for r in fixed if r["ppl"] in fit_ppls]
        fit = accuracy.fit_perimeter_constant(
            [(r["seed"], r["target"]) for r in pts], [r["a_fixed"] for r in pts],
            [r["perim_fixed"] for r in pts])
    md.append(f"Seeds {seeds}, points per lambda_s {ppls}. Perimeter constant fitted on the "
              f"fixed-load contact areas at ppl {fit_ppls}: c = {c_all:.4f}"
              + (f" (rms residual {fit.rms:.2e}, {fit.n} points)" if fit else "")
              + "; each seed is corrected with c fitted on the other seeds.\n")

    # fixed-load a_c and mean gap against resolution
    rows = []
    for target in sorted({r["target"] for r in fixed}):
        for p in ppls:
            e_a, e_g, e_c = [], [], []
            for s in seeds:
                rr = {q["ppl"]: q for q in fixed if q["seed"] == s and q["target"] == target}
                if p not in rr or max(ppls) not in rr:
                    continue
                ref = rr[max(ppls)]
                fine_ppls = sorted(rr)[-2:]
                a_ref = accuracy.richardson(rr[fine_ppls[0]]["a_fixed"],
                                            rr[fine_ppls[1]]["a_fixed"],
                                            ratio=fine_ppls[1] / fine_ppls[0])
                e_a.append(rr[p]["a_fixed"] - a_ref)
                cs = _fit_c(fixed, fit_ppls, exclude_seed=s) if len(seeds) > 1 else c_all
                e_c.append(rr[p]["a_fixed"] - cs * rr[p]["perim_fixed"] - a_ref)
                e_g.append(rr[p]["gap_fixed"] / ref["gap_fixed"] - 1)
            if e_a:
                rows.append([target, _ppl(p, ppls[-2:]), float(np.mean(e_a)),
                             float(np.mean(e_c)),
                             float(np.mean(np.abs(e_g)))])
    md.append("## Contact area and mean gap at fixed load\n")
    md.append("Error of a_c against the Richardson extrapolation of the two finest grids; "
              "perimeter-corrected a_c; relative error of the mean gap against the finest grid "
              f"(means over seeds; 0 on the finest grid by construction). {EXTRAP_NOTE}\n")
    md.append(_md_table(["a_c target", "ppl", "a_c error", "corrected a_c error",
                         "|mean gap rel. error|"], rows) + "\n")

    # a_c* against resolution: raw, corrected, Richardson
    fig, axs = plt.subplots(1, 3, figsize=(15, 4.5))
    pareto = {}
    f0, f1 = (ppls[-2], ppls[-1]) if len(ppls) > 1 else (ppls[-1], ppls[-1])
    if thr and len(ppls) >= 2:
        rows = []
        refs = {}
        for s in seeds:
            rr = {q["ppl"]: q for q in thr if q["seed"] == s}
            f0, f1 = ppls[-2], ppls[-1]
            for ax in (0, 1):
                refs[(s, ax)] = accuracy.richardson(rr[f0][f"a_star_{ax}"],
                                                    rr[f1][f"a_star_{ax}"], ratio=f1 / f0)
        spread = np.std([refs[(s, 0)] for s in seeds] + [refs[(s, 1)] for s in seeds], ddof=1)
        variants = {"raw": [], "perimeter": [], "richardson": []}
        for p in ppls:
            err = {k: [] for k in variants}
            tt = {k: [] for k in variants}
            for s in seeds:
                rr = {q["ppl"]: q for q in thr if q["seed"] == s}
                cs = _fit_c(fixed, fit_ppls, exclude_seed=s) if len(seeds) > 1 else c_all
                t_raw = rr[p]["time"]
                for ax in (0, 1):
                    v = rr[p][f"a_star_{ax}"]
                    ref = refs[(s, ax)]
                    err["raw"].append(v - ref)
                    tt["raw"].append(t_raw)
                    vc = v - cs * rr[p].get(f"perim_{ax}", rr[p]["perim_mid"])
                    err["perimeter"].append(vc - ref)
                    tt["perimeter"].append(t_raw + rr[p]["time_mid"])
                    csv_rows.append(f"a_c_star_{'xy'[ax]},raw,{p},{s},{v},{ref},{v - ref},{t_raw}")
                    csv_rows.append(f"a_c_star_{'xy'[ax]},perimeter,{p},{s},{vc},{ref},"
                                    f"{vc - ref},{t_raw + rr[p]['time_mid']}")
                    if p // 2 in rr and p < f1:  # at f1 it is the reference itself
                        vr = accuracy.richardson(rr[p // 2][f"a_star_{ax}"], v)
                        err["richardson"].append(vr - ref)
                        tr = t_raw + rr[p // 2]["time"]
                        tt["richardson"].append(tr)
                        csv_rows.append(f"a_c_star_{'xy'[ax]},richardson,{p // 2}+{p},{s},{vr},"
                                        f"{ref},{vr - ref},{tr}")
            for k in variants:
                if err[k]:
                    e = np.asarray(err[k])
                    variants[k].append((p, float(np.median(tt[k])), float(np.sqrt(np.mean(e**2))),
                                        float(np.mean(e)), float(np.std(e, ddof=1)) if e.size > 1
                                        else float("nan")))
        for k, v in variants.items():
            for p, t, rms, mean, sd in v:
                rows.append([k, _ppl(p, (f0, f1)) if k != "richardson" else p, t, mean, rms,
                             sd])
        md.append("## a_c* against resolution (both axes)\n")
        md.append(f"Reference: Richardson extrapolation (first order) of the two finest grids "
                  f"(ppl {ppls[-2]}, {ppls[-1]}), per seed and axis. Seed-to-seed standard "
                  f"deviation of the reference a_c*: {spread:.4f} (over {len(seeds)} seeds x 2 "
                  f"axes). Time: median wall time of one threshold (both axes) per seed; "
                  f"Richardson = both grids; perimeter = threshold + one contact solve. "
                  f"{EXTRAP_NOTE}\n")
        md.append(_md_table(["variant", "ppl", "time [s]", "mean error", "rms error",
                             "sd of error over seeds"], rows) + "\n")
        pareto["a_c_star"] = variants
        ax = axs[0]
        for i, (k, v) in enumerate(variants.items()):
            if v:
                col = f"C{i}"
                ax.loglog([t for _, t, *_ in v], [max(r, 1e-5) for _, _, r, *_ in v], "o-",
                          color=col, label=f"{k}: rms per seed")
                ax.loglog([t for _, t, *_ in v], [max(abs(m), 1e-5) for _, _, _, m, _ in v],
                          "s--", color=col, mfc="none", label=f"{k}: |mean| (bias)")
                for p, t, r, *_ in v:
                    ax.annotate(_plot_label(p, (f0, f1), k), (t, max(r, 1e-5)), fontsize=7)
        ax.axhline(0.01 / 3, color="k", ls=":", label="1/3 of seed SE (0.01)")
        ax.set_xlabel("wall time per threshold [s]")
        ax.set_ylabel("rms error of a_c*")
        ax.set_title("a_c* (x and y), labels: points per lambda_s\n"
                     f"{PLOT_EXTRAP_NOTE}", fontsize=9)
        ax.legend(fontsize=7)

    # sigma at fixed a_c against resolution: raw a_c, and a_c perimeter-corrected
    # each seed's reference a_c*(x) where its searches bracketed one
    a_star_x = ({s: refs[(s, 0)] for s in seeds if math.isfinite(refs[(s, 0)])}
                if thr and len(ppls) >= 2 else {})
    rows = []
    for j, target in enumerate(TARGETS):
        pts = {"raw": [], "perimeter": [], "richardson": []}
        refs = {}
        for s in seeds:
            rr = {q["ppl"]: q for q in sig if q["seed"] == s and q["target"] == target}
            # sigma is nan where the state did not percolate (small cells): no reference
            if f0 in rr and f1 in rr and f0 != f1 and rr[f0]["sigma"] > 0 < rr[f1]["sigma"]:
                refs[s] = accuracy.richardson(math.log(rr[f0]["sigma"]),
                                              math.log(rr[f1]["sigma"]), ratio=f1 / f0)
        for p in ppls:
            e = {k: [] for k in pts}
            tt = []
            for s in seeds:
                rr = {q["ppl"]: q for q in sig if q["seed"] == s and q["target"] == target}
                if p not in rr or s not in refs or not rr[p]["sigma"] > 0:
                    continue
                q = rr[p]
                ref = refs[s]
                cs = _fit_c(fixed, fit_ppls, exclude_seed=s) if len(seeds) > 1 else c_all
                ln_raw = math.log(q["sigma"])
                e["raw"].append(ln_raw - ref)
                ln_cor = _sigma_at_corrected_area(q, target, cs, a_star_x.get(s, A_STAR))
                e["perimeter"].append(ln_cor - ref)
                tt.append(q["time_contact"] + q["time_flow"])
                if p // 2 in rr and p < f1 and rr[p // 2]["sigma"] > 0:
                    ln_ri = accuracy.richardson(math.log(rr[p // 2]["sigma"]), ln_raw)
                    e["richardson"].append(ln_ri - ref)
                    t_ri = tt[-1] + rr[p // 2]["time_contact"] + rr[p // 2]["time_flow"]
                    csv_rows.append(f"ln_sigma_{target},richardson,{p // 2}+{p},{s},{ln_ri},"
                                    f"{ref},{ln_ri - ref},{t_ri}")
                csv_rows.append(f"ln_sigma_{target},raw,{p},{s},{ln_raw},{ref},{ln_raw - ref},"
                                f"{tt[-1]}")
                csv_rows.append(f"ln_sigma_{target},perimeter,{p},{s},{ln_cor},{ref},"
                                f"{ln_cor - ref},{tt[-1]}")
            for k in pts:
                if e[k]:
                    ea = np.asarray(e[k])
                    rms = float(np.sqrt(np.mean(ea**2)))
                    t_k = float(np.median(tt))
                    if k == "richardson":  # both grids
                        t_k += float(np.median([pp[1] for pp in pts["raw"] if pp[0] == p // 2]))
                    pts[k].append((p, t_k, rms, float(np.mean(ea))))
                    rows.append([target, k, _ppl(p, (f0, f1)) if k != "richardson" else p,
                                 t_k, float(np.mean(ea)), rms])
        if len(refs) > 1:
            md.append(f"Seed-to-seed sd of ln sigma at a_c = {target} (reference): "
                      f"{np.std(list(refs.values()), ddof=1):.3f}\n")
        ax = axs[1 + j]
        for k, v in pts.items():
            if v:
                ax.loglog([t for _, t, *_ in v], [max(r, 1e-4) for _, _, r, *_ in v], "o-",
                          label=k)
                for p, t, r, *_ in v:
                    ax.annotate(_plot_label(p, (f0, f1), k), (t, max(r, 1e-4)), fontsize=7)
        ax.set_xlabel("wall time (contact to target + flow) [s]")
        ax.set_ylabel("rms |ln(sigma / sigma_ref)|")
        ax.set_title(f"sigma_x at a_c = {target}\n{PLOT_EXTRAP_NOTE}", fontsize=9)
        ax.legend(fontsize=7)
    md.append("## sigma_x at fixed a_c against resolution\n")
    md.append("Error: ln sigma minus the Richardson extrapolation (first order) of ln sigma "
              "over the two finest grids. raw: sigma at raw a_c = target; perimeter: sigma at "
              "perimeter-corrected a_c = target (shifted along the load path with the local "
              "slope d ln sigma / d a_c = 3 d ln(mean gap)/d a_c - (69/20)/(a_c* - a_c), "
              "Eq. 16, the mean-gap derivative measured from the two nearest solves). Time: "
              "contact solves to reach the target area (warm-started secant) + one flow "
              f"solve. {EXTRAP_NOTE}\n")
    md.append(_md_table(["a_c", "variant", "ppl", "time [s]", "mean ln error", "rms ln error"],
                        rows) + "\n")
    fig.tight_layout()
    fig.savefig(outdir / "convergence_resolution.png", dpi=120)
    plt.close(fig)

    # tolerances
    fig, axs = plt.subplots(1, 3, figsize=(15, 4.5))
    ct = [r for r in tol if r["kind"] == "contact_tol"]
    if ct:
        rows = []
        tols = sorted({r["contact_tol"] for r in ct}, reverse=True)
        tref = min(tols)
        for target in TARGETS:
            pts = []
            for ctl in tols:
                ea, eg, es, tt, it = [], [], [], [], []
                for r in ct:
                    if r["target"] != target or r["contact_tol"] != ctl:
                        continue
                    ref = next((q for q in ct if q["seed"] == r["seed"]
                                and q["target"] == target and q["contact_tol"] == tref), None)
                    if ref is None:
                        continue
                    ea.append(abs(r["a"] - ref["a"]))
                    eg.append(abs(r["mean_gap"] / ref["mean_gap"] - 1))
                    es.append(abs(r["sigma"] / ref["sigma"] - 1) if ref["sigma"] > 0 else 0.0)
                    tt.append(r["time_contact"])
                    it.append(r["iterations"])
                if not ea:
                    continue
                rows.append([target, ctl, float(np.median(tt)), float(np.median(it)),
                             float(np.max(ea)), float(np.max(eg)), float(np.max(es))])
                pts.append((ctl, float(np.median(tt)), max(float(np.max(ea)), 1e-7)))
            axs[0].semilogy([t for _, t, _ in pts], [e for *_, e in pts], "o-",
                          label=f"a_c ~ {target}")
            for c, t, e in pts:
                axs[0].annotate(f"{c:g}", (t, e), fontsize=7)
        md.append(f"## Contact solver tolerance (ppl {ct[0]['ppl']}, cold solves, "
                  f"reference tol {tref:g})\n")
        md.append(_md_table(["a_c", "contact tol", "time [s]", "iterations", "max |d a_c|",
                             "max |d gap|/gap", "max |d sigma|/sigma"], rows) + "\n")
        axs[0].axhline(0.01 / 3, color="k", ls=":")
        axs[0].set_xlabel("contact solve wall time [s]")
        axs[0].set_ylabel("max |a_c - a_c(ref)|")
        axs[0].set_title("contact tolerance (labels: tol)")
        axs[0].legend(fontsize=7)
    tct = [r for r in tol if r["kind"] == "threshold_contact_tol"]
    if tct:
        rows = []
        tols = sorted({r["contact_tol"] for r in tct}, reverse=True)
        tref = min(tols)
        for ctl in tols:
            e, tt = [], []
            for r in tct:
                if r["contact_tol"] != ctl:
                    continue
                ref = next((q for q in tct if q["seed"] == r["seed"]
                            and q["contact_tol"] == tref), None)
                if ref is None:
                    continue
                e += [abs(r["a_star_0"] - ref["a_star_0"]), abs(r["a_star_1"] - ref["a_star_1"])]
                tt.append(r["time"])
            if not e:
                continue
            rows.append([ctl, float(np.median(tt)), float(np.max(e))])
        md.append(f"## Contact tolerance inside the threshold search (bisection tol "
                  f"{tct[0]['bisect_tol']:g}, reference contact tol {tref:g})\n")
        md.append(_md_table(["contact tol", "time [s]", "max |d a_c*|"], rows) + "\n")
        axs[1].semilogy([r[1] for r in rows], [max(r[2], 1e-6) for r in rows], "o-",
                      label="a_c* vs contact tol")
        for r in rows:
            axs[1].annotate(f"{r[0]:g}", (r[1], max(r[2], 1e-6)), fontsize=7)
        axs[1].set_xlabel("threshold wall time [s]")
        axs[1].set_ylabel("max |a_c* - a_c*(ref)|")
        axs[1].set_title("contact tol in the threshold")
        axs[1].axhline(0.01 / 3, color="k", ls=":")
    bt = [r for r in tol if r["kind"] == "bisect_tol"]
    if bt:
        rows = []
        tols = sorted({r["bisect_tol"] for r in bt}, reverse=True)
        tref = min(tols)
        pts = []
        for btl in tols:
            e, tt, ns = [], [], []
            for r in bt:
                if r["bisect_tol"] != btl:
                    continue
                ref = next((q for q in bt if q["seed"] == r["seed"]
                            and q["bisect_tol"] == tref), None)
                if ref is None:
                    continue
                e += [r["a_star_0"] - ref["a_star_0"], r["a_star_1"] - ref["a_star_1"]]
                tt.append(r["time"])
                ns.append(r["n_solves"])
            if not e:
                continue
            ea = np.asarray(e)
            rows.append([btl, float(np.median(tt)), float(np.median(ns)),
                         float(np.sqrt(np.mean(ea**2))), float(np.max(np.abs(ea)))])
            pts.append((btl, float(np.median(tt)), max(float(np.sqrt(np.mean(ea**2))), 1e-6)))
        md.append(f"## Bisection tolerance (ppl {bt[0]['ppl']}, reference tol {tref:g})\n")
        md.append(_md_table(["bisection tol", "time [s]", "contact solves", "rms |d a_c*|",
                             "max |d a_c*|"], rows) + "\n")
        axs[2].semilogy([t for _, t, _ in pts], [e for *_, e in pts], "o-", label="a_c*")
        for b, t, e in pts:
            axs[2].annotate(f"{b:g}", (t, e), fontsize=7)
        axs[2].axhline(0.01 / 3, color="k", ls=":", label="1/3 of seed SE")
        axs[2].set_xlabel("threshold wall time [s]")
        axs[2].set_ylabel("rms |a_c* - a_c*(ref)|")
        axs[2].set_title("bisection tolerance (labels: tol)")
        axs[2].legend(fontsize=7)
    _write(outdir, "convergence", md, csv_rows, fig, "convergence_tolerances.png")


# ---------------------------------------------------------------------------------------
# anisotropic report: per direction, and the face weighting of the perimeter term
# ---------------------------------------------------------------------------------------

#: Two weightings of the contact/non-contact faces, computed from the stored face counts per
#: cell (tx: faces normal to x, ty: normal to y) and the spacings, so that records written
#: with any version of ``accuracy.perimeter_term`` compare alike. "geometric": face length
#: times the geometric-mean spacing sqrt(dx dy) (the form calibrated on square cells before
#: issue 20); "pixel": face length times the spacing normal to the face, i.e. one cell area
#: per face whatever the cell's aspect ratio. Both are (tx + ty) on square cells.
FORMS = ("geometric", "pixel")


def _face_term(r: dict, suffix: str, form: str) -> float:
    tx, ty = r[f"tx{suffix}"], r[f"ty{suffix}"]
    if form == "pixel":
        return tx + ty
    q = math.sqrt(r["dy"] / r["dx"])
    return tx * q + ty / q


def _lstsq_groups(groups: list, a: np.ndarray, terms: np.ndarray) -> tuple[np.ndarray, float]:
    """a = a_inf(group) + terms @ c (several constants; :func:`accuracy.fit_perimeter_constant`
    is the one-constant case): returns (c, rms residual)."""
    labels = sorted(set(groups), key=str)
    idx = {lab: i for i, lab in enumerate(labels)}
    design = np.zeros((a.size, len(labels) + terms.shape[1]))
    for k, lab in enumerate(groups):
        design[k, idx[lab]] = 1.0
    design[:, len(labels):] = terms
    coef, *_ = np.linalg.lstsq(design, a, rcond=None)
    return coef[len(labels):], float(np.sqrt(np.mean((a - design @ coef) ** 2)))


def _fit_form(pts: list[dict], form: str, exclude_seed=None) -> accuracy.PerimeterFit:
    pts = [r for r in pts if r["seed"] != exclude_seed]
    return accuracy.fit_perimeter_constant(
        [(r["gamma"], r["seed"], r["target"]) for r in pts], [r["a_fixed"] for r in pts],
        [_face_term(r, "_fixed", form) for r in pts])


def _jackknife_c(pts: list[dict], form: str) -> float:
    """Leave-one-seed-out (jackknife) standard error of the fitted constant."""
    seeds = sorted({(r["gamma"], r["seed"]) for r in pts})
    if len(seeds) < 3:
        return float("nan")
    cs = np.array([_fit_form([r for r in pts if (r["gamma"], r["seed"]) != gs], form).c
                   for gs in seeds])
    return float(np.sqrt((len(cs) - 1) / len(cs) * np.sum((cs - cs.mean()) ** 2)))


def _direction(gamma: float, ax: int) -> str:
    if gamma == 1.0:
        return "x" if ax == 0 else "y"
    return ("easy (x)" if ax == 0 else "hard (y)") if gamma > 1 else (
        "hard (x)" if ax == 0 else "easy (y)")


def report_anisotropic(args) -> None:
    """Per-direction resolution study over every gamma with a resolution file (issue 20)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    outdir = Path(args.out)
    files = sorted(outdir.glob("convergence_resolution*.jsonl"))
    recs = [r for f in files for r in _load(f)]
    for r in recs:
        r.setdefault("gamma", 1.0)
    recs = [r for r in recs if "tx_0" in r or "tx_fixed" in r]  # face counts stored
    gammas = sorted({r["gamma"] for r in recs})
    if not gammas:
        return
    c0 = accuracy.PERIMETER_C
    md = ["# Anisotropic resolution study (benchmarks/convergence.py report)\n",
          "Same physical surface at every resolution (generated at the finest grid, sampled "
          "h[::k, ::k]); ppl = points per shortest wavelength along each axis, so cells are "
          "gamma:1 rectangles. Reference: first-order Richardson extrapolation of the two "
          "finest grids per seed (and axis). Face terms: tx, ty = contact/non-contact faces "
          "normal to x, y per cell; 'geometric' = tx sqrt(dy/dx) + ty sqrt(dx/dy) (the "
          f"pre-issue-20 perimeter_term), 'pixel' = tx + ty. {EXTRAP_NOTE}\n"]
    csv = ["gamma,quantity,direction,variant,ppl,seed,value,reference,error"]
    fixed_all = []
    rows_fit, rows_fixed, rows_thr = [], [], []
    fig, axs = plt.subplots(1, len(gammas), figsize=(5 * len(gammas), 4.2), squeeze=False)
    for gi, g in enumerate(gammas):
        rg = [r for r in recs if r["gamma"] == g]
        thr = [r for r in rg if r["kind"] == "threshold"]
        fixed = [r for r in rg if r["kind"] in ("sigma", "fixed") and "tx_fixed" in r]
        ppls = sorted({r["ppl"] for r in thr})
        seeds = sorted(s for s in {r["seed"] for r in thr}
                       if all(any(r["seed"] == s and r["ppl"] == p for r in thr) for p in ppls))
        fit_ppls = [p for p in ppls if p >= args.fit_min_ppl]
        if len(fit_ppls) < 2 or not seeds:  # nothing complete yet
            continue
        f0, f1 = ppls[-2], ppls[-1]
        pts = [r for r in fixed if r["ppl"] in fit_ppls and r["seed"] in seeds]
        fixed_all += pts
        cfit = {}
        for form in FORMS:
            f = _fit_form(pts, form)
            cfit[form] = f
            rows_fit.append([g, form, f.c, _jackknife_c(pts, form), f.rms, f.n])
        tx_ty = np.mean([r["tx_fixed"] / r["ty_fixed"] for r in pts])
        cxy, rms_xy = _lstsq_groups([(r["seed"], r["target"]) for r in pts],
                                    np.array([r["a_fixed"] for r in pts]),
                                    np.array([[r["tx_fixed"], r["ty_fixed"]] for r in pts]))
        rows_fit.append([g, f"pixel, c_x and c_y (tx/ty = {tx_ty:.2f}: nearly collinear)",
                         f"{cxy[0]:.4f} / {cxy[1]:.4f}", "", rms_xy, len(pts)])
        # fixed-load areas against resolution
        for target in sorted({r["target"] for r in fixed}):
            for p in ppls:
                e = {k: [] for k in ("raw", *FORMS)}
                for s in seeds:
                    rr = {q["ppl"]: q for q in fixed if q["seed"] == s and q["target"] == target}
                    if p not in rr or f0 not in rr or f1 not in rr:
                        continue
                    ref = accuracy.richardson(rr[f0]["a_fixed"], rr[f1]["a_fixed"],
                                              ratio=f1 / f0)
                    e["raw"].append(rr[p]["a_fixed"] - ref)
                    for form in FORMS:
                        e[form].append(rr[p]["a_fixed"] - c0 * _face_term(rr[p], "_fixed", form)
                                       - ref)
                if e["raw"]:
                    rows_fixed.append([g, target, _ppl(p, (f0, f1)),
                                       *[float(np.mean(e[k])) for k in e]])
        # a_c* per direction
        refs = {}
        for s in seeds:
            rr = {q["ppl"]: q for q in thr if q["seed"] == s}
            for ax in (0, 1):
                refs[(s, ax)] = accuracy.richardson(rr[f0][f"a_star_{ax}"],
                                                    rr[f1][f"a_star_{ax}"], ratio=f1 / f0)
        for ax in (0, 1):
            d = _direction(g, ax)
            # the constant that would remove the first-order error of a_c* itself, fitted
            # on this direction's thresholds at the two finest grids (at 4 points per
            # lambda_s the percolation jitter, sd ~0.014, swamps it); jackknife over seeds
            tp = [dict(q, gamma=g, target=None, a_fixed=q[f"a_star_{ax}"],
                       tx_fixed=q[f"tx_{ax}"], ty_fixed=q[f"ty_{ax}"])
                  for q in thr if q["ppl"] in (f0, f1) and q["seed"] in seeds]
            if len(seeds) > 2:
                ft = _fit_form(tp, "pixel")
                rows_fit.append([g, f"pixel, fitted on a_c* {d} (ppl {f0}, {f1})", ft.c,
                                 _jackknife_c(tp, "pixel"), ft.rms, ft.n])
            curves = {k: [] for k in ("raw", *FORMS, "pixel, c fitted")}
            for p in ppls:
                e = {k: [] for k in curves}
                for s in seeds:
                    q = next(r for r in thr if r["seed"] == s and r["ppl"] == p)
                    v, ref = q[f"a_star_{ax}"], refs[(s, ax)]
                    vals = {"raw": v}
                    for form in FORMS:
                        vals[form] = v - c0 * _face_term(q, f"_{ax}", form)
                    c_loo = _fit_form(pts, "pixel", exclude_seed=s).c if len(seeds) > 1 \
                        else cfit["pixel"].c
                    vals["pixel, c fitted"] = v - c_loo * _face_term(q, f"_{ax}", "pixel")
                    for k, val in vals.items():
                        e[k].append(val - ref)
                        csv.append(f"{g},a_c_star,{d},{k},{p},{s},{val},{ref},{val - ref}")
                for k in curves:
                    ea = np.asarray(e[k])
                    sd = float(np.std(ea, ddof=1)) if ea.size > 1 else float("nan")
                    curves[k].append((p, float(np.mean(ea)), sd / math.sqrt(ea.size)))
                    rows_thr.append([g, d, k, _ppl(p, (f0, f1)), float(np.mean(ea)),
                                     sd / math.sqrt(ea.size),
                                     sd, len(ea)])
            for k, col in zip(curves, ("k", "C0", "C3", "C2"), strict=True):
                xs = [p for p, *_ in curves[k]]
                axs[0, gi].errorbar(xs, [m for _, m, _ in curves[k]],
                                    yerr=[se for *_, se in curves[k]], color=col, capsize=2,
                                    ls="-" if ax == 0 else "--", marker="o" if ax == 0 else "s",
                                    label=f"{d}: {k}")
        ax_ = axs[0, gi]
        ax_.axhline(0, color="gray", lw=0.8)
        ax_.axhspan(-0.0033, 0.0033, color="gray", alpha=0.15, lw=0)
        ax_.set_xscale("log", base=2)
        ax_.set_xlabel("points per lambda_s (each axis)")
        ax_.set_ylabel("a_c* error (mean over seeds +- SE)")
        ax_.set_title(f"gamma = {g:g} ({len(seeds)} seeds, c = {c0})")
        ax_.legend(fontsize=6)
    if len({r["gamma"] for r in fixed_all}) > 1:
        for form in FORMS:
            f = _fit_form(fixed_all, form)
            rows_fit.append(["pooled", form, f.c, _jackknife_c(fixed_all, form), f.rms, f.n])
        cxy, rms_xy = _lstsq_groups([(r["gamma"], r["seed"], r["target"]) for r in fixed_all],
                                    np.array([r["a_fixed"] for r in fixed_all]),
                                    np.array([[r["tx_fixed"], r["ty_fixed"]]
                                              for r in fixed_all]))
        rows_fit.append(["pooled", "pixel, c_x and c_y", f"{cxy[0]:.4f} / {cxy[1]:.4f}", "",
                         rms_xy, len(fixed_all)])
    md.append(f"## Perimeter constant fitted on fixed-load areas (ppl >= {args.fit_min_ppl})\n")
    md.append(_md_table(["gamma", "face weighting", "c", "jackknife SE over seeds",
                         "rms residual", "points"], rows_fit)
              + "\n")
    md.append(f"## Fixed-load contact area error (mean over seeds; corrections with c = {c0})\n")
    md.append(_md_table(["gamma", "a_c target (law)", "ppl", "raw", "geometric", "pixel"],
                        rows_fixed) + "\n")
    md.append(f"## a_c* error per direction (raw; corrected with c = {c0} and each face "
              "weighting; pixel with c fitted on the other seeds of this gamma)\n")
    md.append(_md_table(["gamma", "direction", "variant", "ppl", "bias", "SE of bias",
                         "sd over seeds", "seeds"], rows_thr) + "\n")
    _write(outdir, "convergence_anisotropic", md, csv, fig, "convergence_anisotropic.png")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("phase", choices=("resolution", "tol", "report", "all"))
    ap.add_argument("--out", default="results/benchmarks", help="output folder")
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2], help="surface seeds")
    ap.add_argument("--ppl", type=int, nargs="+", default=[2, 4, 8, 16],
                    help="points per lambda_s of the resolution study (each divides the max)")
    ap.add_argument("--gamma", type=float, default=1.0,
                    help="Peklenik number of the resolution study (file name carries it)")
    ap.add_argument("--l-over-lambda-r", type=float, default=None,
                    help="L / lambda_r of the resolution study (default: the paper's)")
    ap.add_argument("--sigma", action=argparse.BooleanOptionalAction, default=None,
                    help="sigma at a_c = 0.2, 0.35 (flow solves); default only for gamma 1")
    ap.add_argument("--fixed-targets", type=float, nargs="+", default=[0.2, 0.35, 0.42],
                    help="without --sigma: a_c of the contact law's fixed loads (c fit)")
    ap.add_argument("--bisect-tol", type=float, default=1e-3,
                    help="bisection tol (a_hi - a_lo) of the resolution study")
    ap.add_argument("--threshold-contact-tol", type=float, default=1e-5,
                    help="contact tol inside threshold searches")
    ap.add_argument("--contact-tol", type=float, default=1e-6,
                    help="contact tol of the fixed-area solves of the resolution study")
    ap.add_argument("--area-tol", type=float, default=3e-4,
                    help="how close a_c must come to the sigma targets")
    ap.add_argument("--tol-ppl", type=int, default=4, help="resolution of the tolerance study")
    ap.add_argument("--contact-tols", type=float, nargs="+",
                    default=[1e-3, 1e-4, 1e-5, 1e-6, 1e-8], help="contact tols (last = ref)")
    ap.add_argument("--threshold-contact-tols", type=float, nargs="+",
                    default=[1e-3, 1e-4, 1e-5, 1e-7], help="contact tols inside the threshold")
    ap.add_argument("--threshold-bisect-tol", type=float, default=1e-3,
                    help="bisection tol of the contact-tol study inside the threshold")
    ap.add_argument("--bisect-tols", type=float, nargs="+",
                    default=[0.032, 0.016, 0.008, 0.004, 0.002, 0.001, 0.0005, 0.00025],
                    help="bisection tols (last = reference)")
    ap.add_argument("--fit-min-ppl", type=int, default=4,
                    help="smallest resolution used to fit the perimeter constant")
    args = ap.parse_args(argv)
    if args.phase != "report":
        _warm_up()
    if args.phase in ("tol", "all"):
        phase_tol(args)
    if args.phase in ("resolution", "all"):
        phase_resolution(args)
    if args.phase in ("report", "all"):
        if resolution_file(args.out, 1.0).exists():  # the isotropic tables need it
            report(args)
        report_anisotropic(args)
    return 0


if __name__ == "__main__":
    sys.exit(main())
