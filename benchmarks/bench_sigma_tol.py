"""Flow solves stopped at a proven sigma accuracy (``flow.solve(sigma_tol=)``) against solves
to the residual and flux criteria, side by side on the states of an elastic ladder.

For each size, an isotropic H = 0.8 surface (eps_f = 1/16, 4 points per lambda_s, seed 0;
n = 64 L/lambda_r) is brought by warm-started elastic contact solves (tol 1e-6, the
ladder's) to the pressures that give about the paper's ladder areas (a_c 0.01 - 0.4). Each
state and axis is solved ``--repeats`` times by each variant, alternated (``method`` as the
ladder uses it: ``auto``, which takes RS on open states and the direct solver on thin
clusters; ``--method rs`` forces RS everywhere). Per case: median time, CG iterations,
the reported bound on sigma's error, and the relative distance between the two sigmas
(at most the looser one's bound, since each sigma is at least the exact one).

    ROUGHFLOW_FFT_THREADS=1 python benchmarks/bench_sigma_tol.py --sizes 512 1024

Writes results/benchmarks/bench_sigma_tol{tag}.{csv,md}.
"""

from __future__ import annotations

import argparse
import csv
import logging
import os
import statistics
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("ROUGHFLOW_FFT_THREADS", "1")

from roughflow import contact, flow  # noqa: E402
from roughflow.defaults import FLOW_SIGMA_TOL  # noqa: E402
from roughflow.surface import SurfaceSpec, generate  # noqa: E402

OUT = Path(__file__).resolve().parents[1] / "results" / "benchmarks"
#: pressures (E* gbar) that give a_c of about 0.01, 0.03, 0.05, 0.1, 0.15, 0.2, 0.25, 0.3,
#: 0.36, 0.4 on these surfaces (a_c about 2.2 p)
PRESSURES = (0.0045, 0.0135, 0.0225, 0.045, 0.068, 0.09, 0.113, 0.136, 0.163, 0.181)


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[512, 1024])
    ap.add_argument("--pressures", type=float, nargs="+", default=list(PRESSURES))
    ap.add_argument("--sigma-tol", type=float, default=FLOW_SIGMA_TOL)
    ap.add_argument("--method", default="auto", choices=("auto", "rs", "sa"))
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--tag", default="")
    return ap


def main() -> None:
    args = build_parser().parse_args()
    logging.disable(logging.WARNING)
    OUT.mkdir(parents=True, exist_ok=True)
    variants = {"tol": None, "sigma_tol": args.sigma_tol}
    # untimed solves of every variant on a small state first: the flow code's numba kernels
    # compile (or load from numba's cache) at their first call, which would be timed
    s0 = generate(SurfaceSpec.from_sweep(points_per_lambda_s=2, seed=1))
    g0 = contact.solve(s0, 0.09).gap
    for method in {args.method, "direct"}:  # auto takes direct on thin clusters
        for st in variants.values():
            flow.solve(g0, 0, lx=s0.lx, ly=s0.ly, method=method, sigma_tol=st)
    rows = []
    for n in args.sizes:
        spec = SurfaceSpec.from_sweep(hurst=0.8, eps_f=1 / 16, points_per_lambda_s=4, seed=0,
                                      l_over_lambda_r=n / 64)
        s = generate(spec)
        assert s.shape == (n, n), s.shape
        state = None
        for p in args.pressures:
            state = contact.solve(s, p, tol=1e-6, init=state)
            for axis in (0, 1):
                times = {k: [] for k in variants}
                out = {}
                for _ in range(args.repeats):
                    for k, st in variants.items():
                        t0 = time.perf_counter()
                        out[k] = flow.solve(state.gap, axis, lx=s.lx, ly=s.ly,
                                            method=args.method, sigma_tol=st)
                        times[k].append(time.perf_counter() - t0)
                a, b = out["tol"], out["sigma_tol"]
                if not a.percolating:
                    continue
                ta, tb = statistics.median(times["tol"]), statistics.median(times["sigma_tol"])
                row = dict(n=n, a_c=round(state.area_fraction, 4), axis="xy"[axis],
                           unknowns=a.n_active, method=a.method, time_tol_s=ta,
                           time_sigma_tol_s=tb, ratio=tb / ta, iterations_tol=a.iterations,
                           iterations_sigma_tol=b.iterations, error_tol=a.sigma_error,
                           error_sigma_tol=b.sigma_error,
                           distance=(b.sigma - a.sigma) / b.sigma,
                           residual_sigma_tol=b.residual,
                           imbalance_sigma_tol=b.flux_imbalance, repeats=args.repeats)
                rows.append(row)
                print(" ".join(f"{k}={v:.3g}" if isinstance(v, float) else f"{k}={v}"
                               for k, v in row.items()), flush=True)
                with open(OUT / f"bench_sigma_tol{args.tag}.csv", "w", newline="") as fh:
                    w = csv.DictWriter(fh, fieldnames=list(rows[0]))
                    w.writeheader()
                    w.writerows(rows)
    write_markdown(rows, OUT / f"bench_sigma_tol{args.tag}.md", args)


def write_markdown(rows: list[dict], path: Path, args) -> None:
    lines = [f"# Flow solves to sigma_tol = {args.sigma_tol:g} against tol (method "
             f"{args.method}, median of {args.repeats}, alternated)", "",
             "| n | a_c | axis | unknowns | method | time tol [s] | time sigma_tol [s] | ratio "
             "| iterations | error bound | distance | residual | imbalance |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(
            f"| {r['n']} | {r['a_c']:.3f} | {r['axis']} | {r['unknowns']} | {r['method']} | "
            f"{r['time_tol_s']:.3f} | {r['time_sigma_tol_s']:.3f} | {r['ratio']:.2f} | "
            f"{r['iterations_tol']} -> {r['iterations_sigma_tol']} | "
            f"{r['error_tol']:.1e} -> {r['error_sigma_tol']:.1e} | {r['distance']:.1e} | "
            f"{r['residual_sigma_tol']:.1e} | {r['imbalance_sigma_tol']:.1e} |")
    for n in sorted({r["n"] for r in rows}):
        sel = [r for r in rows if r["n"] == n]
        ta = sum(r["time_tol_s"] for r in sel)
        tb = sum(r["time_sigma_tol_s"] for r in sel)
        amg = [r for r in sel if r["method"] != "direct"]
        lines.append("")
        lines.append(f"n = {n}: the ladder's {len(sel)} flow solves take {ta:.2f} s -> {tb:.2f} s "
                     f"({tb / ta:.2f}x); its {len(amg)} AMG solves median ratio "
                     f"{statistics.median(r['ratio'] for r in amg) if amg else float('nan'):.2f}")
    path.write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
