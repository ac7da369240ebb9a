"""What recording sigma's error costs a flow solve (``FlowResult.sigma_error``): direct, AMG.

Usage:
    ROUGHFLOW_FFT_THREADS=1 python benchmarks/bench_sigma_error.py [--sizes 512 1024]
        [--areas 0.1 0.3 0.4] [--repeats 3] [--tag NAME]

Bearing gaps (the top fraction a_c of the heights in contact) of the surface H = 0.8,
L/lambda_r = 4, 4 points per lambda_s, seed 0. For each, the median time of a whole direct
``flow.solve`` along x (which includes the error since it is recorded) and of
``flow.core._sigma_error`` alone (the residual r = b - A p and one more solve with the
factorisation: the bound (max |r| / w + 8 eps)^2 w^T A^-1 w / Q; the scale
w = |A| |p| + |b| is the imbalance floor's, computed by every solve and not timed here),
their ratio, and the error, the imbalance and its round-off floor the solve reports.
Then the same for an RS-AMG solve and its upper bound
(``flow.core._sigma_error_bound``: the divergence of the solve's fluxes routed along the
widest spanning tree, ``flow.bound``), with the bound RS reports. Writes
results/benchmarks/sigma_error[_TAG].{csv,md}; docs/flow.md quotes it.
"""

from __future__ import annotations

import argparse
import functools
import statistics
import sys
import time
from pathlib import Path

import numpy as np

from roughflow.flow import core, solve
from roughflow.flow.linsolve import prepare
from roughflow.reynolds import cubic_law
from roughflow.surface import SurfaceSpec, generate

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_contact import format_row, write_table  # noqa: E402


def _median_time(fn, repeats: int):
    times, out = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), out


def warm_up() -> None:
    """One untimed direct and RS solve on a small gap: the flow code's numba kernels (AMG
    setup, assembly, the RS bound's spanning tree) compile, or load from numba's cache, at
    their first call, which the first timed solve would otherwise include."""
    h = generate(SurfaceSpec.from_sweep(points_per_lambda_s=2, seed=1)).heights
    gap = np.maximum(np.quantile(h, 0.8) - h, 0.0)
    for method in ("direct", "rs"):
        solve(gap, 0, method=method)


def rows_for(n: int, areas: list[float], repeats: int) -> list[dict]:
    s = generate(SurfaceSpec.from_sweep(l_over_lambda_r=4, eps_f=16.0 / n,
                                        points_per_lambda_s=4, seed=0))
    h, lx, ly = s.heights, s.lx, s.ly
    rows = []
    for a_c in areas:
        gap = np.maximum(np.quantile(h, 1.0 - a_c) - h, 0.0)
        t_solve, res = _median_time(
            functools.partial(solve, gap, 0, lx=lx, ly=ly, method="direct"), repeats)
        local = cubic_law(gap)  # eta = 1, as solve's default
        system = core.reynolds_system(local, core.flowing_cells(local, 0), 0, lx=lx, ly=ly)
        factor = prepare(system.matrix, "direct").factor
        x = factor.solve(system.rhs)
        dissipation = res.sigma * system.l_across / system.l_flow  # sigma = Q L_flow / L_across
        # the residual scale is the imbalance floor's, which every solve computes anyway
        scale = core._residual_scale(system.matrix, system.rhs, x)
        t_error, error = _median_time(
            functools.partial(core._sigma_error, system.matrix, system.rhs, x, scale,
                              factor.solve, dissipation), repeats)
        t_rs, rs = _median_time(
            functools.partial(solve, gap, 0, lx=lx, ly=ly, method="rs"), repeats)
        x_rs = rs.pressure.ravel()[system.cells]
        t_bound, bound = _median_time(
            functools.partial(core._sigma_error_bound, system.faces, system.active,
                              system.cells, x_rs), repeats)
        row = {"n": n, "a_c": a_c, "solve_s": t_solve, "sigma_error_s": t_error,
               "ratio": t_error / t_solve, "sigma_error": res.sigma_error,
               "sigma_error_timed": error, "imbalance": res.flux_imbalance,
               "imbalance_floor": res.imbalance_floor, "rs_solve_s": t_rs,
               "rs_iterations": rs.iterations, "bound_s": t_bound,
               "bound_ratio": t_bound / t_rs, "rs_bound": rs.sigma_error,
               "rs_bound_timed": bound, "rs_imbalance_floor": rs.imbalance_floor,
               "rs_minus_direct": (rs.sigma - res.sigma) / res.sigma}
        print(format_row(row), flush=True)
        rows.append(row)
    return rows


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[512, 1024])
    ap.add_argument("--areas", type=float, nargs="+", default=[0.1, 0.3, 0.4])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--tag", default="")
    return ap


def main() -> None:
    args = build_parser().parse_args()
    warm_up()
    rows = [r for n in args.sizes for r in rows_for(n, args.areas, args.repeats)]
    write_table("sigma_error" + (f"_{args.tag}" if args.tag else ""), rows)


if __name__ == "__main__":
    main()
