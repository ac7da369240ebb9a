"""The adhesive minimizer against the grid size: nonlinear CG (``contact.adhesive_cg``) and the
mass-weighted FIRE it replaced, side by side on the same surfaces and loads.

Usage:
    ROUGHFLOW_FFT_THREADS=1 python benchmarks/bench_adhesive.py [--sizes 256 512 1024]
        [--loads 0 0.02 0.05 0.11] [--repeats 3] [--tol 1e-4] [--tag _big]

Surfaces H = 0.8, L/lambda_r = 4, 4 points per lambda_s (eps_f = 16 / n), seed 0; the paper's
adhesive case on the harmonic wall, the one the CG serves (gamma_s / v_ela^full =
ADHESION_SURFACE_ENERGY_RATIO, rho = ADHESION_RANGE_OVER_LAMBDA_S["harmonic"] lambda_s), solved
as ``contact.solve`` does it: from the hard
wall's contact at the same load (at least the start load), to the tolerance ``--tol``. Both
minimizers start from that same state; only the adhesive minimization is timed (median of
``--repeats``). The columns compare the two answers: contact points that differ and the
largest gap difference over rms(h). Writes results/benchmarks/adhesive_minimizer{tag}.{csv,md}.
"""

from __future__ import annotations

import argparse
import functools
import statistics
import sys
import time
from pathlib import Path

import numpy as np

from roughflow.contact import gfmd as G
from roughflow.contact import solve
from roughflow.contact._kernels import warm_up
from roughflow.contact.adhesion import adhesion_for
from roughflow.contact.solve import _ADHESIVE_START_LOAD, _ADHESIVE_START_TOL
from roughflow.defaults import ADHESION_RANGE_OVER_LAMBDA_S, ADHESION_SURFACE_ENERGY_RATIO
from roughflow.surface import SurfaceSpec, generate

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_contact import format_row, write_table  # noqa: E402

#: the minimizers compared, as ``gfmd(..., minimizer=...)`` names them
MINIMIZERS = {"cg": "auto", "fire": "fire"}


def adhesive_solve(s, ad, load: float, tol: float, minimizer: str, start):
    """``solve`` of the adhesive model from ``start`` with ``minimizer`` (timed)."""
    orig = G.gfmd
    G.gfmd = functools.partial(orig, minimizer=minimizer)
    try:
        t0 = time.perf_counter()
        res = solve(s, load, model="adhesive", adhesion=ad, tol=tol, init=start,
                    max_iter=20000)
        return res, time.perf_counter() - t0
    finally:
        G.gfmd = orig


def rows_for(n: int, loads: list[float], tol: float, repeats: int) -> list[dict]:
    s = generate(SurfaceSpec.from_sweep(l_over_lambda_r=4, eps_f=16.0 / n,
                                        points_per_lambda_s=4, seed=0))
    ad = adhesion_for(s.heights, s.lx, s.ly, gamma_over_v_full=ADHESION_SURFACE_ENERGY_RATIO,
                      range=ADHESION_RANGE_OVER_LAMBDA_S["harmonic"] * s.spec.lambda_s,
                      repulsion="harmonic")
    hrms = float(np.std(s.heights))
    rows = []
    for load in loads:
        # the start of contact.solve's adhesive path, made once for both minimizers
        start = solve(s, max(load, _ADHESIVE_START_LOAD), tol=_ADHESIVE_START_TOL)
        # kappa against the largest elastic stiffness |q_max| E*/2 (the grid's corner)
        k_max = np.pi * np.hypot(n / s.lx, n / s.ly) / 2
        row: dict = {"n": n, "load": load, "kappa_over_k_max": ad.kappa / k_max}
        out = {}
        for name, minimizer in MINIMIZERS.items():
            times = []
            for _ in range(repeats):
                res, dt = adhesive_solve(s, ad, load, tol, minimizer, start)
                times.append(dt)
            out[name] = res
            row[f"{name}_iterations"] = res.iterations
            row[f"{name}_s"] = statistics.median(times)
        row["time_ratio"] = row["cg_s"] / row["fire_s"]
        row["a_c"] = out["cg"].area_fraction
        row["differing_points"] = int((out["cg"].contact != out["fire"].contact).sum())
        row["max_gap_diff_over_hrms"] = float(np.abs(out["cg"].gap - out["fire"].gap).max()
                                              / hrms)
        print(format_row(row), flush=True)
        rows.append(row)
    return rows


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[256, 512, 1024])
    ap.add_argument("--loads", type=float, nargs="+", default=[0.0, 0.02, 0.05, 0.11])
    ap.add_argument("--tol", type=float, default=1e-4)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--tag", default="")
    return ap


def main() -> None:
    args = build_parser().parse_args()
    warm_up()
    rows = [r for n in args.sizes for r in rows_for(n, args.loads, args.tol, args.repeats)]
    write_table(f"adhesive_minimizer{args.tag}", rows)


if __name__ == "__main__":
    main()
