"""Hard-wall GFMD at scale: iterations, time per iteration against an FFT pair, total time.

Usage:
    ROUGHFLOW_FFT_THREADS=1 python benchmarks/bench_scaling.py \
        [--sizes 512 1024 2048 4096 8192] [--l-over-lambda-r 4 1] \
        [--before] [--before-max-n 8192] [--before-skip 8192/1] [--threshold] \
        [--rows-from earlier.log] [--repeats 5] [--tag _x]
    ROUGHFLOW_FFT_THREADS=1 python benchmarks/bench_scaling.py --sizes 512 1024 \
        --l-over-lambda-r 4 --threshold-seeds 10 [--threshold-tol 0.002]

Surfaces: H = 0.8, 4 points per lambda_s (lambda_r/lambda_s = n / (4 L/lambda_r)), seed 0;
load 0.2 E* gbar (a_c about 0.4), tol 1e-6, one FFT thread. Per row: the iterations and
wall time of ``solve`` (hard-wall CG; ``--repeats R``: the median of R solves, the first
with the plans' creation), with ``--before`` also of the FIRE minimizer it
replaced (``gfmd(..., minimizer="fire")``, up to ``--before-max-iter`` steps, sizes up to
``--before-max-n``), and the median time of an FFT pair of the same size measured in the
same run, before and after the solves: ``RealFFT2.forward`` + ``inverse`` (what a caller of
``roughflow.fft`` pays, with the copy into the plan and the normalisation) and the bare
FFTW executes (what the solver's kernels use). ``--threshold`` adds the cost of the
critical-area search for both axes (``search.threshold``; bisection tol ``--threshold-tol``,
default ``THRESHOLD_TOL`` = 0.002, the library's; the default workflow's config uses 0.008;
contact tol 1e-4) in cold-solve equivalents: its wall time over
that of one cold solve at the same contact tolerance; ``--threshold-seeds`` also splits each
search into the time inside the minimizer and outside it, with the fit of a solve's time
to a fixed cost plus one per iteration (docs/percolation.md, "Cost model and floor").
``--accuracy 256/0 512/0 1024/1``
instead writes bench_scaling_accuracy.{csv,md}: errors of a_c, mean gap and contact set at
tol 1e-4, 1e-6, 1e-8 against tol 1e-10, CG and FIRE side by side.

Writes results/benchmarks/bench_scaling.{csv,md} and the log-log plot bench_scaling.png
there (``--plot-copy PATH`` also copies it, e.g. to docs/figures/contact_scaling.png).
"""

from __future__ import annotations

import argparse
import contextlib
import functools
import gc
import json
import shutil
import statistics
import sys
import time
from pathlib import Path

import numpy as np

from roughflow import fft
from roughflow.contact import gfmd as G
from roughflow.contact import solve
from roughflow.defaults import THRESHOLD_CONTACT_TOL, THRESHOLD_TOL
from roughflow.search import SearchOptions, first_pressure, threshold, warm_up
from roughflow.surface import Surface, SurfaceSpec, generate

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_contact import write_table  # noqa: E402

OUT = Path(__file__).resolve().parents[1] / "results" / "benchmarks"
LOAD = 0.2
TOL = 1e-6
COLD_REPEATS = 3
#: Issue 14's table: FIRE steps of the code before it, (n, L/lambda_r) -> steps (8192^2 from
#: the same algorithm on a GPU); always plotted (open squares) as the fixed reference, also
#: beside this run's own FIRE rows (--before), which it checks and extends to sizes one CPU
#: thread does not afford.
ISSUE_FIRE_STEPS = {(512, 4.0): 35, (1024, 4.0): 45, (2048, 4.0): 55, (4096, 4.0): 90,
                    (8192, 4.0): 205, (1024, 1.0): 65}


def surface(n: int, l_over_lambda_r: float, seed: int = 0) -> Surface:
    """The benchmark's surface: H 0.8, gamma 1, 4 points per lambda_s, eps_f = 4 L/lambda_r / n."""
    return generate(SurfaceSpec.from_sweep(gamma=1, hurst=0.8, l_over_lambda_r=l_over_lambda_r,
                                           eps_f=4 * l_over_lambda_r / n,
                                           points_per_lambda_s=4, seed=seed))


def fft_pair_ms(n: int, reps: int) -> tuple[float, float]:
    """Median ms of an FFT pair: through the RealFFT2 API, and the bare executes."""
    plan = fft.plan((n, n))
    a = np.random.default_rng(0).random((n, n))
    api, bare = [], []
    for _ in range(reps):
        t0 = time.perf_counter()
        plan.inverse(plan.forward(a))
        api.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        plan.execute_forward()
        np.copyto(plan.spectral_in, plan.spectral_out)
        plan.execute_inverse()
        bare.append(time.perf_counter() - t0)
    return 1e3 * statistics.median(api), 1e3 * statistics.median(bare)


def timed_gfmd(s: Surface, minimizer: str, max_iter: int) -> tuple[int, float, bool, float]:
    t0 = time.perf_counter()
    out = G.gfmd(s.heights, s.lx, s.ly, LOAD, tol=TOL, max_iter=max_iter, minimizer=minimizer)
    return out.iterations, time.perf_counter() - t0, out.converged, out.residual


@contextlib.contextmanager
def minimizer(name: str):
    """Make ``contact.solve`` run the hard wall with ``gfmd(..., minimizer=name)``."""
    orig = G.gfmd
    G.gfmd = functools.partial(orig, minimizer=name)
    try:
        yield
    finally:
        G.gfmd = orig


@contextlib.contextmanager
def solver_clock(log: list[tuple[int, float]]):
    """Append (iterations, seconds) of every ``gfmd`` call made by ``contact.solve`` to
    ``log``: what a search spends inside the minimizer, apart from its own work."""
    orig = G.gfmd

    def timed(*a, **kw):
        t0 = time.perf_counter()
        out = orig(*a, **kw)
        log.append((out.iterations, time.perf_counter() - t0))
        return out

    G.gfmd = timed
    try:
        yield
    finally:
        G.gfmd = orig


#: Threshold-search variants: the hard-wall minimizer. "fire" is the search as it was before
#: issue 14, "cg" the present one.
VARIANTS = {"fire": "fire", "cg": "auto"}


def threshold_cost(s: Surface, variant: str, tol: float = THRESHOLD_TOL,
                   contact_tol: float = THRESHOLD_CONTACT_TOL, **kwargs) -> dict:
    """The two-axis threshold search in cold-solve equivalents: its wall time over that of one
    cold solve of the same surface at a_c about 0.4 (the search's first pressure) and the
    search's contact tolerance (median of :data:`COLD_REPEATS`), both with the variant's
    minimizer; ``kwargs`` go to both (``threads``, ``backend``)."""
    with minimizer(VARIANTS[variant]):
        colds = []
        for _ in range(COLD_REPEATS):  # the unit is short: a median of 3 tames the noise
            t0 = time.perf_counter()
            cold = solve(s, first_pressure(), tol=contact_tol, **kwargs)
            colds.append(time.perf_counter() - t0)
        t_cold = statistics.median(colds)
        solves: list[tuple[int, float]] = []
        with solver_clock(solves):
            t0 = time.perf_counter()
            res = threshold(s, tol=tol, options=SearchOptions(contact_tol=contact_tol), **kwargs)
            t_pair = time.perf_counter() - t0
    solver_s = sum(t for _, t in solves)
    return {"variant": variant, "cold_s": t_cold, "cold_iterations": cold.iterations,
            "cold_a_c": cold.area_fraction, "pair_s": t_pair,
            "pair_cold_equivalents": t_pair / t_cold, "solves": res[0].n_solves,
            "pair_iterations": sum(r.iterations for r in res[0].solves),
            # the cost model of docs/percolation.md: the time inside the minimizer, and each
            # solve's (iterations, seconds) for the fit of a fixed cost plus one per iteration
            "solver_s": solver_s, "outside_solver_s": t_pair - solver_s,
            "solver_cold_equivalents": solver_s / t_cold,
            "solve_times": solves,
            "a_x": res[0].a_c_star, "a_y": res[1].a_c_star,
            "a_x_corrected": res[0].a_c_star_corrected,
            "a_y_corrected": res[1].a_c_star_corrected}


def threshold_seeds(n: int, l_over_lambda_r: float, seeds: int, variants: list[str],
                    tol: float) -> tuple[list[dict], list[dict]]:
    """Per seed, every variant side by side on the same surface; and the summary per variant:
    median cost, mean corrected a_c* per axis and its shift against the first variant, the
    largest per-seed shift of a_c*."""
    rows = []
    times: dict[str, list[tuple[int, float]]] = {}
    for seed in range(seeds):
        s = surface(n, l_over_lambda_r, seed)
        fft.plan(s.shape)
        for v in variants:
            r = {"n": n, "seed": seed, "tol": tol, **threshold_cost(s, v, tol=tol)}
            times.setdefault(v, []).extend(r.pop("solve_times"))  # not a table column
            print(json.dumps(r), flush=True)
            rows.append(r)
    ref = variants[0]
    summary = []
    for v in variants:
        sel = [r for r in rows if r["variant"] == v]
        base = [r for r in rows if r["variant"] == ref]
        out = {"n": n, "tol": tol, "variant": v,
               "median_cold_equivalents": statistics.median(r["pair_cold_equivalents"]
                                                            for r in sel),
               "max_cold_equivalents": max(r["pair_cold_equivalents"] for r in sel),
               "median_solves": statistics.median(r["solves"] for r in sel),
               "median_cold_s": statistics.median(r["cold_s"] for r in sel),
               "median_pair_s": statistics.median(r["pair_s"] for r in sel),
               # with no work outside the minimizer, and the iterations alone
               "median_solver_cold_equivalents": statistics.median(
                   r["solver_cold_equivalents"] for r in sel),
               "median_iterations_cold_equivalents": statistics.median(
                   r["pair_iterations"] / r["cold_iterations"] for r in sel),
               "median_outside_solver_s": statistics.median(r["outside_solver_s"] for r in sel),
               **solve_cost_fit(times[v])}
        for ax in "xy":
            key = f"a_{ax}_corrected"
            out[f"mean_{key}"] = statistics.fmean(r[key] for r in sel)
            out[f"shift_mean_{key}"] = out[f"mean_{key}"] - statistics.fmean(r[key] for r in base)
        out["max_seed_shift"] = max(abs(r[f"a_{ax}"] - b[f"a_{ax}"])
                                    for r, b in zip(sel, base, strict=True) for ax in "xy")
        summary.append(out)
    return rows, summary


def solve_cost_fit(solves: list[tuple[int, float]]) -> dict:
    """Least-squares fit of a solve's time to a + b iterations over ``solves`` ((iterations,
    seconds) each): the fixed cost of a solve and the cost of an iteration, in ms."""
    its, secs = np.array(solves, dtype=float).reshape(-1, 2).T
    if its.size < 2 or np.ptp(its) == 0:
        return {"solve_fixed_ms": float("nan"), "iteration_ms": float("nan")}
    a, b = np.linalg.lstsq(np.column_stack([np.ones_like(its), its]), secs, rcond=None)[0]
    return {"solve_fixed_ms": 1e3 * a, "iteration_ms": 1e3 * b}


def row(n: int, l_over_lambda_r: float, args: argparse.Namespace) -> dict:
    s = surface(n, l_over_lambda_r)
    reps = 7 if n <= 2048 else 3
    fft.plan((n, n))
    pairs = [fft_pair_ms(n, reps)]
    walls = []
    for _ in range(args.repeats):  # the median of repeated solves (plans then cached)
        it, wall, conv, res = timed_gfmd(s, "auto", args.max_iter)
        walls.append(wall)
        pairs.append(fft_pair_ms(n, reps))
    wall = statistics.median(walls)
    r = {"n": n, "L_over_lambda_r": l_over_lambda_r,
         "lambda_r_over_lambda_s": n / (4 * l_over_lambda_r),
         "iterations": it if conv else f">{it} (residual {res:.1e})", "total_s": wall,
         "ms_per_iteration": 1e3 * wall / it}
    skip = f"{n}/{l_over_lambda_r:g}" in args.before_skip
    if args.before and n <= args.before_max_n and not skip:
        b_it, b_wall, b_conv, b_res = timed_gfmd(s, "fire", args.before_max_iter)
        pairs.append(fft_pair_ms(n, reps))
        r.update({"fire_steps": b_it if b_conv else f">{b_it} (residual {b_res:.1e})",
                  "fire_total_s": b_wall, "fire_ms_per_step": 1e3 * b_wall / b_it})
    pair = statistics.median(p[0] for p in pairs)
    bare = statistics.median(p[1] for p in pairs)
    r.update({"ms_per_fft_pair": pair, "ms_per_bare_pair": bare,
              "iteration_over_pair": r["ms_per_iteration"] / pair,
              "iteration_over_bare_pair": r["ms_per_iteration"] / bare})
    if "fire_ms_per_step" in r:
        r["fire_step_over_pair"] = r["fire_ms_per_step"] / pair
    if args.threshold:
        t = threshold_cost(s, "cg", tol=args.threshold_tol)
        r.update({"threshold_s": t["pair_s"],
                  "threshold_cold_solve_equivalents": t["pair_cold_equivalents"]})
    print(json.dumps(r), flush=True)
    del s
    gc.collect()
    return r


def accuracy(cases: list[str]) -> list[dict]:
    """Errors of a_c, mean gap and contact set at tol 1e-4 / 1e-6 / 1e-8 against a tol 1e-10
    reference, for the CG iteration and the FIRE one it replaced (same residual)."""
    rows = []
    for c in cases:
        n, lr = int(c.split("/")[0]), float(c.split("/")[1])
        s = surface(n, lr) if lr > 0 else generate(SurfaceSpec(
            nx=n, ny=n, lx=1.0, ly=1.0, hurst=0.8, gamma=1.0, lambda_r=0.25,
            lambda_s=1 / 64, seed=0))  # bench_contact.py's surfaces
        for p in (0.045, 0.2):
            refs = {m: G.gfmd(s.heights, s.lx, s.ly, p, tol=1e-10, max_iter=20000, minimizer=m)
                    for m in ("auto", "fire")}
            ref = refs["auto"]
            ref_gap = float(ref.gap.mean())
            for m in ("fire", "auto"):
                for tol in (1e-4, 1e-6, 1e-8):
                    t0 = time.perf_counter()
                    o = G.gfmd(s.heights, s.lx, s.ly, p, tol=tol, max_iter=20000, minimizer=m)
                    r = {"case": c, "pressure": p, "method": "fire" if m == "fire" else "cg",
                         "tol": tol, "iterations": o.iterations,
                         "seconds": time.perf_counter() - t0,
                         "err_a_c": abs(float(o.contact.mean()) / float(ref.contact.mean()) - 1),
                         "err_mean_gap": abs(float(o.gap.mean()) / ref_gap - 1),
                         "pixels_differing": int((o.contact != ref.contact).sum()),
                         "refs_mean_gap_diff": abs(float(refs["fire"].gap.mean()) / ref_gap - 1)}
                    rows.append(r)
                    print(json.dumps(r), flush=True)
    return rows


def plot(rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(14, 4.3))
    styles = {4.0: "-", 1.0: "--"}
    for lr, ls in styles.items():
        sel = sorted((r for r in rows if r["L_over_lambda_r"] == lr), key=lambda r: r["n"])
        if not sel:
            continue
        n = [r["n"] for r in sel]
        lab = f"L/lambda_r = {lr:g}"

        def num(v):
            return v if isinstance(v, (int, float)) else np.nan

        axes[0].loglog(n, [num(r["iterations"]) for r in sel], "o" + ls, color="C0",
                       label=f"CG, {lab}")
        fire = [r for r in sel if "fire_steps" in r]
        if fire:
            axes[0].loglog([r["n"] for r in fire], [num(r["fire_steps"]) for r in fire],
                           "s" + ls, color="C3", label=f"FIRE (before), {lab}")
            axes[2].loglog([r["n"] for r in fire], [r["fire_total_s"] for r in fire], "s" + ls,
                           color="C3", label=f"FIRE (before), {lab}")
        axes[1].loglog(n, [r["ms_per_iteration"] for r in sel], "o" + ls, color="C0",
                       label=f"CG iteration, {lab}")
        axes[1].loglog(n, [r["ms_per_fft_pair"] for r in sel], "x" + ls, color="k",
                       label=f"FFT pair, {lab}")
        axes[2].loglog(n, [r["total_s"] for r in sel], "o" + ls, color="C0", label=f"CG, {lab}")
    # the issue's FIRE step counts (8192^2 from a GPU run: 24 GiB and one CPU thread do not
    # afford FIRE there)
    for lr, ls in styles.items():
        ref = sorted((n, v) for (n, lr_), v in ISSUE_FIRE_STEPS.items() if lr_ == lr)
        axes[0].loglog([n for n, _ in ref], [v for _, v in ref], "s" + ls, mfc="none",
                       color="C3", label=f"FIRE, issue 14's table, L/lambda_r = {lr:g}")
    axes[0].axhline(60, color="0.6", lw=0.8, label="target 60")
    axes[0].set_ylabel("iterations to tol 1e-6")
    axes[1].set_ylabel("ms per iteration / per FFT pair (1 thread)")
    axes[2].set_ylabel("total time to tol 1e-6 (s)")
    sizes = sorted({r["n"] for r in rows})
    # the iterations panel also draws the issue's sizes: label those ticks too (the others
    # keep this run's, since a tick outside the data would widen the axis)
    all_sizes = sorted(set(sizes) | {n for n, _ in ISSUE_FIRE_STEPS})
    for ax, ticks in zip(axes, (all_sizes, sizes, sizes), strict=True):
        ax.set_xlabel("n (grid n x n)")
        ax.set_xticks(ticks, [str(n) for n in ticks])
        ax.minorticks_off()
        ax.grid(True, which="major", alpha=0.3)
        ax.legend(fontsize=7)
    axes[0].set_yticks([20, 30, 40, 60, 90, 200], ["20", "30", "40", "60", "90", "200"])
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", type=int, nargs="*", default=[512, 1024, 2048, 4096, 8192])
    ap.add_argument("--l-over-lambda-r", type=float, nargs="*", default=[4.0, 1.0])
    ap.add_argument("--max-iter", type=int, default=2000)
    ap.add_argument("--repeats", type=int, default=1,
                    help="time this many solves per row (median) and as many FFT pair sets")
    ap.add_argument("--before", action="store_true", help="also time the FIRE minimizer")
    ap.add_argument("--before-max-n", type=int, default=8192)
    ap.add_argument("--before-max-iter", type=int, default=600)
    ap.add_argument("--before-skip", nargs="*", default=[], help="rows n/L_over_lambda_r")
    ap.add_argument("--threshold", action="store_true",
                    help="add the threshold-search cost in cold-solve equivalents")
    ap.add_argument("--threshold-tol", type=float, default=THRESHOLD_TOL)
    ap.add_argument("--threshold-seeds", type=int, default=0,
                    help="only the threshold-cost table: this many seeds (0..N-1) at --sizes "
                    "and --l-over-lambda-r, every --variants side by side")
    ap.add_argument("--variants", nargs="*", default=list(VARIANTS), choices=list(VARIANTS))
    ap.add_argument("--plot-copy", type=Path, default=None)
    ap.add_argument("--rows-from", type=Path, nargs="*", default=[],
                    help="also the rows printed (one JSON object a line) by earlier runs, "
                    "e.g. to add the largest sizes from a separate run to one table and plot")
    ap.add_argument("--accuracy", nargs="*", default=None,
                    help="only the accuracy table for these cases n/L_over_lambda_r "
                    "(L_over_lambda_r 0: bench_contact.py's surface), e.g. 256/0 512/0 1024/1")
    ap.add_argument("--tag", default="")
    return ap


def main() -> None:
    ap = build_parser()
    args = ap.parse_args()
    if args.repeats < 1:
        ap.error(f"--repeats must be >= 1, got {args.repeats}")
    OUT.mkdir(parents=True, exist_ok=True)
    warm_up()
    if args.accuracy is not None:
        write_table(f"bench_scaling_accuracy{args.tag}", accuracy(args.accuracy))
        return
    if args.threshold_seeds:
        rows, summary = [], []
        for lr in args.l_over_lambda_r:
            for n in args.sizes:
                r, m = threshold_seeds(n, lr, args.threshold_seeds, args.variants,
                                       args.threshold_tol)
                rows += r
                summary += m
        write_table(f"bench_scaling_threshold{args.tag}", rows)
        write_table(f"bench_scaling_threshold_summary{args.tag}", summary)
        return
    rows = [json.loads(line) for f in args.rows_from for line in f.read_text().splitlines()
            if line.startswith("{")]
    rows += [row(n, lr, args) for lr in args.l_over_lambda_r for n in args.sizes]
    write_table(f"bench_scaling{args.tag}", rows)
    png = OUT / f"bench_scaling{args.tag}.png"
    plot(rows, png)
    if args.plot_copy is not None:
        args.plot_copy.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(png, args.plot_copy)


if __name__ == "__main__":
    main()
