"""Percolation: labelling time versus grid size, and the cost of one threshold pair.

Labelling: a contact-like mask (bearing contact of a random-phase surface, H = 0.8,
lambda_r = L/4, 8 points per lambda_s, at a_c = 0.42) labelled periodically
(``label``), tested for spanning (``percolates``, open along x, periodic in y), and the
spanning cells extracted (``spanning_cells``); side by side: scipy.ndimage.label alone
(non-periodic floor) and tamaas' periodic FloodFill.getClusters (peer; skipped when
tamaas is missing or for n above --tamaas-max). Also the exact bearing threshold of both
axes (sort + two union-find sweeps). Medians of --repeats runs.

Threshold pair (elastic, gamma = 1, H = 0.8, L/lambda_r = 4, eps_f = 1/16, the grid
refined to n points: n/64 points per lambda_s): one cold contact solve at the first-guess
pressure (the unit of cost), ``threshold(surface)`` (both axes, shared warm-started
solves, predictor) and the naive reference (plain bisection in a_c, cold starts, each axis
separately). Seeds are the repeats; medians over seeds. All solves use contact_tol = 1e-5.

Usage:
  ROUGHFLOW_FFT_THREADS=1 python benchmarks/bench_percolation.py \\
      [--label-sizes 512 1024 2048 4096 8192] [--repeats 3] \\
      [--thr-sizes 512 1024 2048] [--seeds 3] [--naive-max 1024] [--large 2048]
      [--large-seeds 1]
Writes results/benchmarks/percolation_labelling.{csv,md}, percolation_threshold.{csv,md}
and percolation.png.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
from pathlib import Path

import numpy as np
from scipy import ndimage

os.environ.setdefault("ROUGHFLOW_FFT_THREADS", "1")

from roughflow.contact import solve  # noqa: E402
from roughflow.fft import plan as fft_plan  # noqa: E402
from roughflow.percolation import label, percolates, spanning_cells  # noqa: E402
from roughflow.search import SearchOptions, first_pressure, threshold, warm_up  # noqa: E402
from roughflow.surface import SurfaceSpec, generate  # noqa: E402

OUT = Path(__file__).resolve().parents[1] / "results" / "benchmarks"
CONTACT_TOL = 1e-5


def _median_time(fn, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def bench_labelling(n: int, repeats: int, tamaas_max: int, bearing_max: int) -> dict:
    spec = SurfaceSpec(nx=n, ny=n, lx=1.0, ly=1.0, hurst=0.8, gamma=1.0, lambda_r=0.25,
                       lambda_s=8.0 / n, seed=0)
    surface = generate(spec)
    h = surface.heights
    contact = h > np.quantile(h, 1 - 0.42)
    del h
    fluid = ~contact
    row = {"n": n}
    label(fluid)  # warm-up (imports)
    row["label_s"] = _median_time(lambda: label(fluid), repeats)
    row["percolates_s"] = _median_time(lambda: percolates(fluid, 0), repeats)
    row["spanning_cells_s"] = _median_time(lambda: spanning_cells(fluid, 0), repeats)
    row["ndimage_label_s"] = _median_time(lambda: ndimage.label(fluid), repeats)
    row["bearing_threshold_s"] = float("nan")
    if n <= bearing_max:
        threshold(surface, model="bearing")  # warm-up (numba cache load or compilation)
        row["bearing_threshold_s"] = _median_time(
            lambda: threshold(surface, model="bearing"), repeats)
    row["tamaas_floodfill_s"] = float("nan")
    if n <= tamaas_max:
        try:
            import tamaas

            row["tamaas_floodfill_s"] = _median_time(
                lambda: tamaas.FloodFill.getClusters(fluid, False), repeats)
        except ImportError:
            pass
    print(row, flush=True)
    return row


def bench_threshold(n: int, seed: int, naive: bool) -> dict:
    spec = SurfaceSpec.from_sweep(l_over_lambda_r=4, points_per_lambda_s=n / 64, seed=seed)
    s = generate(spec)
    p0 = first_pressure()
    # plan the FFTs outside the timing (plans are cached per shape); the hard-wall solver
    # uses the float32 plan as well, whose planning (FFTW_MEASURE without wisdom on file)
    # made the timed cold solve, the unit of cost, 4-5x too slow on a fresh machine
    fft_plan(s.shape)
    fft_plan(s.shape, single=True)
    t0 = time.perf_counter()
    cold = solve(s, p0, tol=CONTACT_TOL)
    t_cold = time.perf_counter() - t0
    t0 = time.perf_counter()
    pair = threshold(s, options=SearchOptions(contact_tol=CONTACT_TOL))
    t_pair = time.perf_counter() - t0
    row = {
        "n": spec.nx, "seed": seed, "cold_s": t_cold, "cold_iter": cold.iterations,
        "pair_solves": pair[0].n_solves, "pair_s": t_pair,
        "pair_iter": sum(step[2] for step in pair[0].solves),
        "a_x": pair[0].a_c_star, "a_y": pair[1].a_c_star,
        "naive_solves": float("nan"), "naive_s": float("nan"), "naive_iter": float("nan"),
    }
    if naive:
        t0 = time.perf_counter()
        naive = SearchOptions(strategy="bisect", warm_start=False, contact_tol=CONTACT_TOL)
        res = [threshold(s, ax, options=naive) for ax in (0, 1)]
        row["naive_s"] = time.perf_counter() - t0
        row["naive_solves"] = sum(r.n_solves for r in res)
        row["naive_iter"] = sum(step[2] for r in res for step in r.solves)
        for ax, r in enumerate(res):  # the two methods bracket the same event
            assert abs(r.a_c_star - pair[ax].a_c_star) <= 2e-3 + 1e-12, (r, pair[ax])
    row["pair_cost_in_cold"] = t_pair / t_cold
    row["naive_cost_in_cold"] = row["naive_s"] / t_cold
    print({k: (round(v, 4) if isinstance(v, float) else v) for k, v in row.items()}, flush=True)
    return row


def _write(rows: list[dict], stem: str, fmt: dict) -> str:
    keys = list(rows[0])
    (OUT / f"{stem}.csv").write_text(
        "\n".join([",".join(keys)] + [",".join(f"{r[k]:.6g}" for k in keys) for r in rows])
        + "\n")
    md = ["| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
    md += ["| " + " | ".join(fmt.get(k, "{:.4g}").format(r[k]) for k in keys) + " |"
           for r in rows]
    text = "\n".join(md) + "\n"
    (OUT / f"{stem}.md").write_text(text)
    return text


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--label-sizes", type=int, nargs="+", default=[512, 1024, 2048, 4096, 8192])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--tamaas-max", type=int, default=4096)
    ap.add_argument("--bearing-max", type=int, default=4096,
                    help="largest n for the exact bearing threshold timing")
    ap.add_argument("--thr-sizes", type=int, nargs="*", default=[512, 1024, 2048])
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--naive-max", type=int, default=1024)
    ap.add_argument("--large", type=int, default=2048,
                    help="from this n on, use --large-seeds seeds")
    ap.add_argument("--large-seeds", type=int, default=1)
    return ap


def main() -> None:
    args = build_parser().parse_args()
    OUT.mkdir(parents=True, exist_ok=True)
    warm_up()  # on a fresh install the first timed solve and search would include compiling

    lab = [bench_labelling(n, args.repeats, args.tamaas_max, args.bearing_max)
           for n in args.label_sizes]
    print(_write(lab, "percolation_labelling", {"n": "{:d}"}))

    thr = []
    for n in args.thr_sizes:
        for seed in range(args.seeds if n < args.large else args.large_seeds):
            thr.append(bench_threshold(n, seed, naive=n <= args.naive_max))
    summary = []
    for n in sorted({r["n"] for r in thr}):
        rs = [r for r in thr if r["n"] == n]

        def med(k, rs=rs):
            v = [r[k] for r in rs if not np.isnan(r[k])]
            return statistics.median(v) if v else float("nan")

        summary.append({
            "n": n, "seeds": len(rs), "cold_s": med("cold_s"), "cold_iter": med("cold_iter"),
            "pair_solves": med("pair_solves"), "pair_max_solves": max(r["pair_solves"] for r in rs),
            "pair_s": med("pair_s"), "pair_cost_in_cold": med("pair_cost_in_cold"),
            "pair_max_cost_in_cold": max(r["pair_cost_in_cold"] for r in rs),
            "naive_solves": med("naive_solves"), "naive_s": med("naive_s"),
            "naive_cost_in_cold": med("naive_cost_in_cold"),
        })
    if thr:
        _write(thr, "percolation_threshold_runs", {"n": "{:d}", "seed": "{:d}"})
        print(_write(summary, "percolation_threshold", {"n": "{:d}", "seeds": "{:d}"}))
    _plot(lab, summary)


def _plot(lab: list[dict], summary: list[dict]) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axs = plt.subplots(1, 2, figsize=(10, 4))
    n = [r["n"] for r in lab]
    for key, name in [("label_s", "label (periodic)"), ("percolates_s", "percolates"),
                      ("ndimage_label_s", "ndimage.label (no seams)"),
                      ("bearing_threshold_s", "bearing a_c* (x and y)"),
                      ("tamaas_floodfill_s", "tamaas FloodFill")]:
        axs[0].loglog(n, [r[key] for r in lab], "o-", label=name)
    axs[0].axhline(1.0, color="k", lw=0.5, ls=":")
    axs[0].set_xticks(n, [str(v) for v in n])
    axs[0].minorticks_off()
    axs[0].set_xlabel("n (grid n x n)")
    axs[0].set_ylabel("wall time (s), median")
    axs[0].legend(fontsize=8)
    axs[0].set_title("labelling")
    if summary:
        m = [r["n"] for r in summary]
        axs[1].semilogx(m, [r["pair_cost_in_cold"] for r in summary], "o-",
                        label="threshold pair (shared, warm, predictor)")
        axs[1].semilogx(m, [r["naive_cost_in_cold"] for r in summary], "s-",
                        label="naive (cold bisection, per axis)")
        axs[1].axhline(3.0, color="k", lw=0.5, ls=":", label="target 3")
        axs[1].set_xticks(m, [str(v) for v in m])
        axs[1].set_xlabel("n")
        axs[1].set_ylabel("wall time / one cold solve")
        axs[1].set_yscale("log")
        axs[1].minorticks_off()
        axs[1].set_yticks([1, 2, 3, 5, 10, 20, 50], ["1", "2", "3", "5", "10", "20", "50"])
        axs[1].legend(fontsize=8)
        axs[1].set_title("threshold pair (x and y)")
    fig.tight_layout()
    fig.savefig(OUT / "percolation.png", dpi=120)


if __name__ == "__main__":
    main()
