"""Benchmark of the Reynolds flow solver against scipy and the peer ``reynoldsflow``.

Bearing-model gaps, gap = max(d - h, 0) with d chosen so that the top fraction a_c
of cells is in contact, of an isotropic H = 0.8 surface (L / lambda_r = 4,
lambda_s = L / 64 ... points per lambda_s = n / 64). One axis (x), tolerance 1e-8
(ours) and the peer's own default (1e-12 relative residual). For each case:
median wall time of ``--repeats`` runs, CG iterations, peak traced memory (one
extra untimed run under tracemalloc, which sees numpy/scipy buffers), sigma and
its relative difference to our RS result (``ours-rs``; where that did not run, to the first
solver that did: the table's "rel. diff to" column names it).

Solvers: ours with RS-AMG (default), the same on the hierarchy pyamg builds itself (the
same kernels with pyamg's copies and conversions between them), the same with pyamg's
own hierarchy and V-cycle (identical arithmetic, plus a residual norm before and after
each cycle), RS-AMG with pyamg's default
smoothing (a symmetric Gauss-Seidel sweep before and after each coarse-grid correction,
twice ours) and SA-AMG preconditioning; our direct solver
(``"direct"``: QDLDL's LDL^T with AMD ordering, n <= --direct-max); ``"auto"`` (whichever of the
two ``roughflow.flow.linsolve.choose`` picks for the state); CG without preconditioner
(our assembly, n <= --cg-max, capped at --cg-iters iterations, default 5000: too few
from 128^2 on, where its rows are failures unless the cap is raised to about 20 000);
reynoldsflow with ``scipy.amg-rs`` (its default), ``scipy.amg-sa`` and ``scipy-spsolve``
(n <= --direct-max).

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/bench_flow.py --sizes 512 1024 2048

Sizes must be >= 128 (the surface needs 2 points per lambda_s: n / 64 >= 2).

Writes results/benchmarks/bench_flow.{csv,md,png}.
"""

from __future__ import annotations

import argparse
import csv
import logging
import os
import statistics
import time
import tracemalloc
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("ROUGHFLOW_FFT_THREADS", "1")

import numpy as np  # noqa: E402

from roughflow.flow import amg, linsolve, solve  # noqa: E402
from roughflow.surface import SurfaceSpec, generate  # noqa: E402

OUT = Path(__file__).resolve().parents[1] / "results" / "benchmarks"
#: every solver the script runs, in run order; the plot gives each its own colour from this
#: order (tab20, dark shades first: tab10 has too few for all of them)
SOLVERS = ("ours-rs", "ours-rs-pyamg-setup", "ours-rs-pyamg-cycle", "ours-rs-symmetric",
           "ours-sa", "ours-auto", "ours-direct", "cg-noprec", "rf-amg-rs", "rf-amg-sa",
           "rf-spsolve")


def bearing_gap(heights: np.ndarray, a_c: float) -> np.ndarray:
    """gap = max(d - h, 0) with d at the (1 - a_c) quantile of h (a_c: contact fraction)."""
    d = np.quantile(heights, 1.0 - a_c)
    return np.maximum(d - heights, 0.0)


def _pyamg_cycle(ml, smoothers=None):
    return ml.aspreconditioner(cycle="V")


def ours(method, smoothers=None, pyamg_cycle=False, pyamg_setup=False):
    """Our solver; ``smoothers``: the RS V-cycle's smoothing instead of
    ``amg.RS_SMOOTHERS`` (``{}``: pyamg's default, a symmetric sweep on both sides);
    ``pyamg_setup``: pyamg's own build of the RS hierarchy instead of ``amg.rs_hierarchy``
    (the same kernels, with pyamg's copies and conversions between them);
    ``pyamg_cycle``: pyamg's hierarchy and its own V-cycle instead of ``amg.rs_vcycle`` (the
    same arithmetic with a residual norm before and after each cycle)."""
    def run(gap):
        kept = amg.RS_SMOOTHERS, amg.rs_vcycle, amg.rs_hierarchy
        if smoothers is not None:
            amg.RS_SMOOTHERS = smoothers
        if pyamg_setup or pyamg_cycle:
            amg.rs_hierarchy = amg.pyamg_rs_hierarchy
        if pyamg_cycle:
            amg.rs_vcycle = _pyamg_cycle
        try:
            r = solve(gap, 0, tol=1e-8, method=method)
        finally:
            amg.RS_SMOOTHERS, amg.rs_vcycle, amg.rs_hierarchy = kept
        return r.sigma, r.iterations
    return run


def peer(solver):
    from reynoldsflow.transport import compute_total_flux, solve_fluid_problem

    def run(gap):
        g, _p, flux = solve_fluid_problem(gap, solver=solver)
        if g is None:
            return 0.0, 0
        q, _err = compute_total_flux(g, flux, gap.shape[0])
        return q / 12.0, -1  # reynoldsflow omits the 1/12 of u^3/(12 eta); no iteration count
    return run


def measure(fn, gap, repeats, memory):
    times, out = [], None
    for _ in range(repeats):
        t = time.perf_counter()
        out = fn(gap)
        times.append(time.perf_counter() - t)
    peak = float("nan")
    if memory:
        tracemalloc.start()
        fn(gap)
        peak = tracemalloc.get_traced_memory()[1] / 2**20
        tracemalloc.stop()
    return statistics.median(times), out, peak


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[512, 1024, 2048],
                    help="grid sizes n (n x n), each >= 128")
    ap.add_argument("--ac", type=float, nargs="+", default=[0.1, 0.3, 0.38, 0.45])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--peer-repeats", type=int, default=3,
                    help="repeats for the peer's solvers (slow at n = 2048)")
    ap.add_argument("--direct-max", type=int, default=1024, help="largest n for direct solvers")
    ap.add_argument("--cg-max", type=int, default=512, help="largest n for unpreconditioned CG")
    ap.add_argument("--no-peer", action="store_true")
    ap.add_argument("--no-memory", action="store_true", help="skip all memory runs")
    ap.add_argument("--no-peer-memory", action="store_true", help="skip the peer's memory run")
    ap.add_argument("--cg-iters", type=int, default=5000,
                    help="iteration cap of unpreconditioned CG (5000)")
    # a name the script does not run was dropped without a word (scipy-splu, after the direct
    # solver became QDLDL, timed nothing)
    ap.add_argument("--solvers", nargs="+", default=None, choices=SOLVERS, metavar="SOLVER",
                    help="only these solvers (%(choices)s)")
    ap.add_argument("--tag", default="", help="suffix of the output files")
    ap.add_argument("--report", nargs="+", metavar="CSV", default=None,
                    help="no runs: merge these CSV files into bench_flow{tag}.md/.png")
    return ap


def main() -> None:
    args = build_parser().parse_args()
    if args.report:
        rows = [row for path in args.report for row in read_csv(path)]
        write_markdown(rows, OUT / f"bench_flow{args.tag}.md")
        plot(rows, OUT / f"bench_flow{args.tag}.png")
        return
    logging.disable(logging.INFO)
    linsolve.MAX_ITER_CG = args.cg_iters
    OUT.mkdir(parents=True, exist_ok=True)
    try:
        import reynoldsflow  # noqa: F401

        have_peer = not args.no_peer
    except ImportError:
        have_peer = False

    # warm-up: imports and the peer's numba compilation stay out of the timings
    h0 = generate(SurfaceSpec.from_sweep(points_per_lambda_s=2, seed=1)).heights
    g0 = bearing_gap(h0, 0.2)
    for fn in [ours("rs"), ours("sa"), ours("direct")] + (
        [peer("scipy.amg-rs"), peer("scipy.amg-sa"), peer("scipy-spsolve")] if have_peer else []
    ):
        fn(g0)

    rows = []
    csv_path = OUT / f"bench_flow{args.tag}.csv"
    for n in args.sizes:
        h = generate(SurfaceSpec.from_sweep(points_per_lambda_s=n / 64, seed=0)).heights
        assert h.shape == (n, n), h.shape
        for a_c in args.ac:
            gap = bearing_gap(h, a_c)
            cases = [("ours-rs", ours("rs"), args.repeats, True),
                     ("ours-rs-pyamg-setup", ours("rs", pyamg_setup=True), args.repeats, False),
                     ("ours-rs-pyamg-cycle", ours("rs", pyamg_cycle=True), args.repeats, False),
                     ("ours-rs-symmetric", ours("rs", smoothers={}), args.repeats, False),
                     ("ours-sa", ours("sa"), args.repeats, False),
                     ("ours-auto", ours("auto"), args.repeats, False)]
            if n <= args.direct_max:
                cases.append(("ours-direct", ours("direct"), args.repeats, False))
            if n <= args.cg_max:
                cases.append(("cg-noprec", ours("cg"), 1, False))
            if have_peer:
                cases.append(("rf-amg-rs", peer("scipy.amg-rs"), args.peer_repeats,
                              not args.no_peer_memory))
                cases.append(("rf-amg-sa", peer("scipy.amg-sa"), args.peer_repeats, False))
                if n <= args.direct_max:
                    cases.append(("rf-spsolve", peer("scipy-spsolve"), args.peer_repeats, False))
            if args.solvers:
                cases = [c for c in cases if c[0] in args.solvers]
            ref, ref_name = None, ""
            for name, fn, reps, mem in cases:
                try:
                    t, (sigma, its), peak = measure(fn, gap, reps, mem and not args.no_memory)
                except Exception as exc:  # a failing solver is a result, not a crash
                    print(f"n={n} a_c={a_c} {name}: FAILED {exc}", flush=True)
                    rows.append(dict(n=n, a_c=a_c, solver=name, time_s=float("nan"),
                                     iterations=getattr(exc, "iterations", -1),
                                     mem_mib=float("nan"), sigma=float("nan"),
                                     rel_diff=float("nan"), repeats=reps, ref_solver=""))
                    continue
                if ref is None:  # ours-rs runs first: the reference unless it failed
                    ref, ref_name = sigma, name
                rel = sigma / ref - 1.0 if ref else float("nan")
                row = dict(n=n, a_c=a_c, solver=name, time_s=t, iterations=its, mem_mib=peak,
                           sigma=sigma, rel_diff=rel, repeats=reps, ref_solver=ref_name)
                rows.append(row)
                print(f"n={n} a_c={a_c} {name}: {t:.3f}s it={its} mem={peak:.0f}MiB "
                      f"sigma={sigma:.10e} rel={rel:.1e}", flush=True)
            with open(csv_path, "w", newline="") as fh:
                w = csv.DictWriter(fh, fieldnames=list(rows[0]))
                w.writeheader()
                w.writerows(rows)
    write_markdown(rows, OUT / f"bench_flow{args.tag}.md")
    plot(rows, OUT / f"bench_flow{args.tag}.png")


def read_csv(path):
    with open(path, newline="") as fh:
        out = []
        for r in csv.DictReader(fh):
            out.append(dict(n=int(r["n"]), a_c=float(r["a_c"]), solver=r["solver"],
                            time_s=float(r["time_s"]), iterations=int(r["iterations"]),
                            mem_mib=float(r["mem_mib"]), sigma=float(r["sigma"]),
                            rel_diff=float(r["rel_diff"]), repeats=int(r["repeats"]),
                            ref_solver=r.get("ref_solver")))  # absent in older files
        return out


def write_markdown(rows, path):
    lines = ["| n | a_c | solver | time (s) | CG its | peak mem (MiB) | sigma | rel. diff | "
             "rel. diff to | t / t(rf fastest) |", "|---|---|---|---|---|---|---|---|---|---|"]
    for n, a_c in sorted({(r["n"], r["a_c"]) for r in rows}):
        group = [r for r in rows if r["n"] == n and r["a_c"] == a_c]
        # files written before ref_solver was stored: the reference was the group's first
        # solver with a result
        first = next((r["solver"] for r in group if np.isfinite(r["sigma"])), "")
        peers = [r["time_s"] for r in group if r["solver"].startswith("rf-")
                 and np.isfinite(r["time_s"])]
        best = min(peers) if peers else float("nan")
        for r in group:
            its = "" if r["iterations"] < 0 else str(r["iterations"])
            lines.append(
                f"| {n} | {a_c} | {r['solver']} | {r['time_s']:.3g} | {its} | "
                f"{r['mem_mib']:.0f} | {r['sigma']:.6e} | {r['rel_diff']:.1e} | "
                f"{r['ref_solver'] if r['ref_solver'] is not None else first} | "
                f"{r['time_s'] / best:.2f} |"
            )
    path.write_text("\n".join(lines) + "\n")


def plot(rows, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    solvers = sorted({r["solver"] for r in rows}, key=lambda s: (
        SOLVERS.index(s) if s in SOLVERS else len(SOLVERS), s))
    shades = [*range(0, 20, 2), *range(1, 20, 2)]
    colors = {s: plt.cm.tab20(shades[i % 20]) for i, s in enumerate(solvers)}
    # the measured contact fractions, the lower half in the left panel, the upper in the
    # right; one panel when there is only one fraction (the right one would be empty)
    fractions = sorted({r["a_c"] for r in rows})
    half = (len(fractions) + 1) // 2
    sets = [fractions[:half], fractions[half:]] if len(fractions) > 1 else [fractions]
    fig, axes = plt.subplots(1, len(sets), figsize=(5.5 * len(sets), 4.5), squeeze=False)
    for ax, a_c_set in zip(axes[0], sets, strict=True):
        for solver in solvers:
            for a_c, ls in zip(a_c_set, ("-", "--", ":", "-."), strict=False):
                pts = sorted((r["n"] ** 2, r["time_s"]) for r in rows
                             if r["solver"] == solver and r["a_c"] == a_c
                             and np.isfinite(r["time_s"]))
                if pts:
                    x, y = zip(*pts, strict=True)
                    ax.loglog(x, y, ls, marker="o", color=colors[solver],
                              label=f"{solver} a_c={a_c}")
        cells = np.array(sorted({r["n"] ** 2 for r in rows}), float)
        t0 = np.nanmedian([r["time_s"] for r in rows if r["n"] ** 2 == cells[0]])
        ax.loglog(cells, cells / cells[0] * t0, "-", lw=3, alpha=0.3, color="gray",
                  label="linear in cells")
        ax.set_xlabel("cells")
        ax.set_ylabel("wall time, one axis (s)")
        styles = ("solid", "dashed", "dotted", "dash-dot")
        ax.set_title(", ".join(f"a_c = {a} ({st})" for a, st in zip(a_c_set, styles,
                                                                       strict=False)),
                     fontsize=8)
        ax.legend(fontsize=6, ncol=2)
    fig.tight_layout()
    fig.savefig(path, dpi=120)


if __name__ == "__main__":
    main()
